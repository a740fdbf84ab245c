"""What the worker tells the UI: frozen snapshots in a one-slot, newest-wins mailbox.

The UI reads the newest snapshot once per frame; older ones are simply replaced, so a slow UI
never makes the worker wait and a fast worker never floods the UI.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from morf.pipeline.control import Progress

# Worker states, in the words the status line uses.
STATE_WORDS = {
    "idle": "idle",
    "running": "running",
    "paused": "paused",
    "stopping": "stopping",
    "finished": "finished",
    "stopped": "stopped",
    "failed": "failed",
}


@dataclass(frozen=True)
class LossCurve:
    """One loss over the run so far (decimated to a bounded length).

    Fields:
        steps: (K,) float64 step numbers; values: (K,) float64 loss values. Read-only arrays.
    """

    steps: np.ndarray
    values: np.ndarray


@dataclass(frozen=True)
class Snapshot:
    """One view of the worker, safe to read from the UI thread.

    Fields:
        seq: increases with every publish (the UI re-uploads preview images only when it changes).
        state: a key of ``STATE_WORDS``.
        stage: the stage running or last run ("fit", "train", ...), or None.
        progress: the stage's newest :class:`Progress` (images are read-only copies), or None.
        curves: loss name -> :class:`LossCurve`.
        elapsed_s: running time of the stage, pauses excluded.
        seconds_per_step: smoothed time per step, None until two reports arrived.
        eta_s: estimated time left, None when unknown.
        error: one line of text when the last stage or command failed, else None.
        message: the worker's last event in words ("frame 12 dropped").
        review_rev: increases whenever the worker changed review.json.
        project: the project folder the worker has open, or None.
        project_rev: increases when the worker opened a project on its own (the project a
            pipeline run just ingested): the UI opens it too.
        chain_step: (i, n) while step i of a pipeline run's n steps runs, else None.
        stage_rev: increases whenever a stage of a pipeline run ended (the UI re-reads what it wrote).
    """

    seq: int = 0
    state: str = "idle"
    stage: str | None = None
    progress: Progress | None = None
    curves: dict[str, LossCurve] = field(default_factory=dict)
    elapsed_s: float = 0.0
    seconds_per_step: float | None = None
    eta_s: float | None = None
    error: str | None = None
    message: str = ""
    review_rev: int = 0
    project: str | None = None
    project_rev: int = 0
    chain_step: tuple[int, int] | None = None
    stage_rev: int = 0

    @property
    def busy(self) -> bool:
        """True while a stage holds the worker (running, paused or stopping)."""
        return self.state in ("running", "paused", "stopping")


class Mailbox:
    """One slot, newest wins. The lock is held only to swap a reference.

    ``on_publish`` (optional) is called after each publish, on the publishing thread: the UI's
    frame loop uses it to wake up and draw the new snapshot.
    """

    def __init__(self, initial: Snapshot | None = None, on_publish: Callable[[], None] | None = None):
        self._lock = threading.Lock()
        self._value = initial if initial is not None else Snapshot()
        self._on_publish = on_publish

    def publish(self, snapshot: Snapshot) -> None:
        with self._lock:
            self._value = snapshot
        if self._on_publish is not None:
            self._on_publish()

    def latest(self) -> Snapshot:
        with self._lock:
            return self._value
