"""Where rendered frames go: a video file (.mp4 / .m4v / .mov / .webm) and/or a folder of PNGs.

Which codec a video gets is decided in :mod:`morf.playback.video_writer` (H.264 or VP9 with PyAV,
else OpenCV's mp4v); ``VideoSink.codec`` says which, for the command to tell the user.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.io import atomic_path, write_image
from morf.io.outputs import RECORD, OutputClaim, claim_output_file, claim_output_folder, write_record
from morf.playback.video_writer import VIDEO_SUFFIXES, Codec, choose_codec, open_video_writer


def is_video_path(out: str | Path) -> bool:
    return Path(out).suffix.lower() in VIDEO_SUFFIXES


def claim_sink(out: str | Path, command: str, force: bool = False) -> OutputClaim:
    """The output rule (:mod:`morf.io.outputs`) for a video file or a PNG folder, checked before
    any rendering: an existing video, or a folder holding files, needs ``force``."""
    out = Path(out)
    if is_video_path(out):
        return claim_output_file(out, command, force)
    if out.suffix:
        raise InputError(f"output must be a video file ({', '.join(VIDEO_SUFFIXES)}) or a folder, got {out}")
    return claim_output_folder(out, command, force)


class VideoSink:
    """Write (H, W, 3) uint8 RGB frames to ``out``: a video file (written atomically: the video
    appears only when complete) or a folder (frames 000000.png, ...; with a record of them, so a
    later ``--force`` replaces these and deletes the ones it does not write again, nothing else)."""

    def __init__(self, out: str | Path, fps: float, size: tuple[int, int], command: str = "morf play",
                 claim: OutputClaim | None = None):
        self.out = Path(out)
        self.is_video = is_video_path(self.out)
        self.command = command
        self.claim = claim if claim is not None else claim_sink(self.out, command)
        self.count = 0
        self.codec: Codec | None = None  # the video's codec (None for a PNG folder)
        self._writer = None
        self._ctx = None
        if self.is_video:
            self.codec = choose_codec(self.out)
            self._ctx = atomic_path(self.out)
            tmp = self._ctx.__enter__()
            try:
                self._writer = open_video_writer(tmp, fps, size, self.codec)
            except BaseException as e:
                self._ctx.__exit__(type(e), e, None)
                raise
        else:
            self.out.mkdir(parents=True, exist_ok=True)

    def write(self, rgb: np.ndarray) -> None:
        if self.is_video:
            self._writer.write(rgb)
        else:
            write_image(self.out / f"{self.count:06d}.png", rgb)
        self.count += 1

    def close(self, ok: bool = True) -> None:
        if not self.is_video:
            written = {f"{i:06d}.png" for i in range(self.count)}
            if ok:  # frames an earlier, longer render left: this command's own, so they go
                for name in self.claim.previous - written - {RECORD}:
                    (self.out / name).unlink(missing_ok=True)
            write_record(self.out, self.command, written if ok else written | self.claim.previous)
        if self._writer is not None:
            writer, self._writer = self._writer, None
            try:
                writer.close()
            except BaseException as e:
                self._ctx.__exit__(type(e), e, None)
                raise
            if ok:
                self._ctx.__exit__(None, None, None)
                self.out.chmod(0o644)  # the temporary file was private; a finished video is not
            else:
                self._ctx.__exit__(RuntimeError, RuntimeError("aborted"), None)
