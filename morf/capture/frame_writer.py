"""A new project's frames written one at a time into its staging folder, with the stage's progress.

``morf ingest`` (a video or images) and the dataset import (``morf dataset``) build a project the
same way: each frame is read, labelled, and written with its person mask under the names a
:class:`~morf.capture.project.CaptureProject` reads, while a terminal bar and the stage's
:class:`~morf.pipeline.control.Progress` reports follow along and a pause or a stop is honoured
between frames. What differs between them (reading, labelling, what is kept per frame) stays in
their loops; this is the part they share.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Iterator, TypeVar

import numpy as np

from morf.capture.project import CaptureProject
from morf.pipeline.control import Progress, StageControl
from morf.progress import progress

T = TypeVar("T")


class FrameWriter:
    """Writes frame ``n`` and its mask into ``folder`` (``frames/000000<ext>``,
    ``masks/000000.png``) and reports it as ``"<verb> frame <n + 1>"`` of ``total`` for ``stage``.
    A context manager: leaving it closes the bar."""

    def __init__(self, folder: Path, ext: str, stage: str, verb: str, total: int | None, control: StageControl):
        self._project = CaptureProject(folder, {"frame_ext": ext})  # its file names, nothing else
        self._stage, self._verb, self._total, self._control = stage, verb, total, control
        self._bar = progress(total=total, desc=stage, unit="frame")

    def numbered(self, items: Iterable[T]) -> Iterator[tuple[int, T]]:
        """``items`` numbered from 0, each handed out once a pause is over (a stop raises
        :class:`~morf.pipeline.control.StopRequested` before the next one)."""
        for n, item in enumerate(items):
            self._control.check()
            yield n, item

    def write(self, n: int, rgb: np.ndarray, mask: np.ndarray) -> None:
        """Frame ``n``: (H, W, 3) uint8 RGB and (H, W) bool person mask; then the progress."""
        self._project.save_frame(n, rgb)
        self._project.save_mask(n, mask)
        self._bar.update(1)
        self._control.report(Progress(self._stage, n + 1, self._total, f"{self._verb} frame {n + 1}", frame=n))

    def __enter__(self) -> "FrameWriter":
        return self

    def __exit__(self, *exc) -> None:
        self._bar.close()
