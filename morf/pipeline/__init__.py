"""How long-running stages (ingest, fit, train, export) report progress and obey pause/stop.

The CLI and the studio's worker thread run the same stage functions; each accepts an optional
:class:`StageControl`. The CLI passes one that draws a progress bar; the studio passes one that
publishes snapshots to the UI and reads the UI's commands. :mod:`morf.pipeline.chain` runs
stages one after another, skipping finished ones and resuming stopped ones (``morf run``,
``morf demo``).
"""

from morf.pipeline.control import Progress, StageControl, StopRequested

__all__ = ["Progress", "StageControl", "StopRequested"]
