"""Where rendered frames go: an .mp4 (OpenCV, mp4v) and/or a folder of PNGs."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.io import atomic_path, write_image


class VideoSink:
    """Write (H, W, 3) uint8 RGB frames to ``out``: a path ending in .mp4 (written atomically:
    the video appears only when complete) or a folder (frames 000000.png, ...)."""

    def __init__(self, out: str | Path, fps: float, size: tuple[int, int]):
        self.out = Path(out)
        self.is_video = self.out.suffix.lower() in (".mp4", ".m4v", ".mov")
        self.count = 0
        self._writer = None
        self._ctx = None
        if self.is_video:
            import cv2

            self._ctx = atomic_path(self.out)
            tmp = self._ctx.__enter__()
            self._writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*"mp4v"), float(fps), tuple(size))
            if not self._writer.isOpened():
                self._ctx.__exit__(InputError, None, None)
                raise InputError(f"cannot open a video writer for {self.out}")
        else:
            if self.out.suffix:
                raise InputError(f"output must be a .mp4 file or a folder, got {self.out}")
            self.out.mkdir(parents=True, exist_ok=True)

    def write(self, rgb: np.ndarray) -> None:
        if self.is_video:
            self._writer.write(np.ascontiguousarray(rgb[..., ::-1]))
        else:
            write_image(self.out / f"{self.count:06d}.png", rgb)
        self.count += 1

    def close(self, ok: bool = True) -> None:
        if self._writer is not None:
            self._writer.release()
            self._writer = None
            if ok:
                self._ctx.__exit__(None, None, None)
                self.out.chmod(0o644)  # the temporary file was private; a finished video is not
            else:
                self._ctx.__exit__(RuntimeError, RuntimeError("aborted"), None)
