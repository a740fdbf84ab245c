"""Small command objects the UI sends to the worker thread through a ``queue.Queue``.

They are plain frozen values: the UI never hands the worker a model, an array or a callback.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from studio.pipeline_run import PipelineRequest


@dataclass(frozen=True)
class StartStage:
    """Run a pipeline stage ("fit", "train", ...) on the open project."""

    stage: str
    options: dict = field(default_factory=dict)  # stage-specific overrides of the default config


@dataclass(frozen=True)
class RunPipeline:
    """Make (or continue) a project as ``morf run`` does: ingest, fit, train, export; a
    :class:`studio.pipeline_run.PipelineRequest` says which folder, from what, and how far."""

    request: "PipelineRequest"


@dataclass(frozen=True)
class Pause:
    """Pause the running stage at its next safe point."""


@dataclass(frozen=True)
class Resume:
    """Resume a paused stage."""


@dataclass(frozen=True)
class Stop:
    """Stop the running stage at its next safe point (its last checkpoint is kept)."""


@dataclass(frozen=True)
class DropFrame:
    """The user drops frame ``index`` from training (saved to review.json at once)."""

    index: int


@dataclass(frozen=True)
class RestoreFrame:
    """Use frame ``index`` again: undo the user's drop, or keep it against the automatic filter."""

    index: int


@dataclass(frozen=True)
class OpenProject:
    """Point the worker at a project folder (None: no project)."""

    root: str | None


@dataclass(frozen=True)
class Shutdown:
    """Stop any stage and end the worker thread."""


Command = StartStage | RunPipeline | Pause | Resume | Stop | DropFrame | RestoreFrame | OpenProject | Shutdown
