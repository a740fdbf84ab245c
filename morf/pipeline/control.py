"""Progress snapshots and cooperative pause/stop for pipeline stages."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Callable

import numpy as np


class StopRequested(Exception):
    """Raised inside a stage by :meth:`StageControl.check` when the user asked to stop.

    Stages catch nothing: they save their state (checkpoint) before calling ``check`` at safe
    points, so stopping there keeps the last checkpoint.
    """


@dataclass(frozen=True)
class Progress:
    """One snapshot of a running stage, safe to hand to another thread.

    Fields:
        stage: "ingest" | "fit" | "train" | "export" | ...
        step: steps done; total: planned steps (None if unknown).
        message: a short human sentence ("fitting body pose, stage 2/3").
        losses: name -> latest scalar value.
        images: name -> (H, W, 3) uint8 preview images (e.g. "render", "warp_flow").
        frame: the frame index the snapshot is about, if any.
    """

    stage: str
    step: int = 0
    total: int | None = None
    message: str = ""
    losses: dict[str, float] = field(default_factory=dict)
    images: dict[str, np.ndarray] = field(default_factory=dict)
    frame: int | None = None


class StageControl:
    """Passed into stages. ``report`` publishes progress; ``check`` honours pause and stop.

    The default instance does nothing but can still be stopped from another thread.
    """

    def __init__(self, on_progress: Callable[[Progress], None] | None = None):
        self._on_progress = on_progress
        self._stop = threading.Event()
        self._running = threading.Event()
        self._running.set()

    # ---- called by stages ---------------------------------------------------------------
    def report(self, progress: Progress) -> None:
        if self._on_progress is not None:
            self._on_progress(progress)

    def check(self) -> None:
        """Block while paused; raise :class:`StopRequested` once a stop was asked for."""
        while not self._running.wait(timeout=0.1):
            if self._stop.is_set():
                break
        if self._stop.is_set():
            raise StopRequested()

    @property
    def stop_requested(self) -> bool:
        return self._stop.is_set()

    # ---- called by whoever drives the stage (UI thread, signal handler) ------------------
    def pause(self) -> None:
        self._running.clear()

    def resume(self) -> None:
        self._running.set()

    def stop(self) -> None:
        self._stop.set()
        self._running.set()

    @property
    def paused(self) -> bool:
        return not self._running.is_set()
