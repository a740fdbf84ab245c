"""What a path dropped on the studio's window is, so the drop does the obvious thing.

A video starts a new project from it (the start screen's form), a folder of images likewise, a
capture project opens, a motion file plays in the live render panel, any other folder becomes the
motion folder. The suffix decides for files; a folder needs a look inside, which
:func:`classify_drop` takes on a thread of its own (:class:`DropClassifier`): the UI thread
never waits on the disk.
"""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Callable

from morf.capture.project import CaptureProject
from morf.motion.library import MOTION_SUFFIXES

VIDEO_SUFFIXES = (".mp4", ".mov", ".avi", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
LOOK_AT = 200  # entries of a dropped folder looked at to call it a folder of frames
KINDS = ("video", "motion", "project", "frames", "folder", "other")


def kind_by_name(path: str) -> str | None:
    """"video" or "motion" from the suffix alone; None when only the disk can tell."""
    suffix = Path(path).suffix.lower()
    if suffix in VIDEO_SUFFIXES:
        return "video"
    if suffix in MOTION_SUFFIXES:
        return "motion"
    return None


def classify_drop(path: str) -> str:
    """One of :data:`KINDS`: by name for videos and motions; a folder is a capture "project", a
    folder of "frames" (images and no motions among its first :data:`LOOK_AT` entries), or a
    "folder" (for the motion browser); anything else is "other"."""
    named = kind_by_name(path)
    if named is not None:
        return named
    p = Path(path)
    try:
        if not p.is_dir():
            return "other"
        if CaptureProject.is_project(p):
            return "project"
        images = motions = 0
        with os.scandir(p) as it:
            for k, entry in enumerate(it):
                if k >= LOOK_AT:
                    break
                suffix = Path(entry.name).suffix.lower()
                images += suffix in IMAGE_SUFFIXES
                motions += suffix in MOTION_SUFFIXES
    except OSError:
        return "other"
    return "frames" if images and not motions else "folder"


def suggested_folder(source: str) -> str:
    """Where a project made from ``source`` goes unless the user says otherwise: beside it,
    named after it (``clip.mp4`` -> ``clip_project``; a folder ``frames/`` -> ``frames_project``)."""
    p = Path(source.rstrip("/\\") or source)
    stem = p.stem if p.suffix.lower() in VIDEO_SUFFIXES else p.name
    return str(p.with_name(f"{stem or 'capture'}_project"))


class DropClassifier:
    """Classifies dropped paths on its own thread; :meth:`take` hands back the finished ones, in
    the order they were dropped. ``on_done`` (called on that thread) asks the UI for a frame."""

    def __init__(self, on_done: Callable[[], None] = lambda: None):
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="morf-drop")
        self._on_done = on_done
        self._pending: list[tuple[str, Future]] = []

    def add(self, path: str) -> None:
        future = self._pool.submit(classify_drop, path)
        future.add_done_callback(lambda _: self._on_done())
        self._pending.append((path, future))

    def take(self) -> list[tuple[str, str]]:
        """(path, kind) of the drops classified so far (the first unfinished one and those after wait)."""
        done = []
        while self._pending and self._pending[0][1].done():
            path, future = self._pending.pop(0)
            done.append((path, future.result()))
        return done

    @property
    def busy(self) -> bool:
        return bool(self._pending)

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
