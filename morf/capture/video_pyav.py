"""Video decoding with PyAV (FFmpeg's libraries): per-frame presentation times and rotation.

Phone clips are often variable frame rate (the camera drops its rate in low light) and are stored
sideways with a display matrix saying how to turn them. OpenCV gives neither the real time of
each frame nor, on every build, the rotation; PyAV gives both. Used by
:func:`morf.capture.video.open_video` when ``av`` is importable (``pip install av``, the ``video``
extra); without it the OpenCV decoder is used as before.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np


def pyav_available() -> bool:
    """Whether PyAV imports (an install without FFmpeg's libraries counts as absent)."""
    try:
        importlib.import_module("av")
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class VideoProbe:
    """What the container says and what the first frame shows.

    Fields:
        width, height: frame size after turning the frame upright (pixels).
        fps: average frame rate (None when unknown).
        frame_count: frames in the stream (exact when the container says, else duration x rate;
            None when neither is known).
        rotation: counter-clockwise degrees the stored frames are turned by for display
            (the display matrix; 0, 90, 180 or -90), already a multiple of 90.
        codec: the stream's codec name ("h264", "hevc", ...).
    """

    width: int
    height: int
    fps: float | None
    frame_count: int | None
    rotation: int
    codec: str


@dataclass(frozen=True)
class DecodedFrame:
    """One decoded frame: its position in the stream, presentation time and upright pixels.

    Fields:
        index: 0-based position among all decoded frames.
        time: seconds since the stream's first frame (None when the frame has no timestamp).
        rgb: (H, W, 3) uint8, turned upright; None for frames the caller did not keep.
    """

    index: int
    time: float | None
    rgb: np.ndarray | None


def quarter_turns(degrees: float) -> int:
    """Counter-clockwise display rotation in degrees -> quarter turns in 0..3 (nearest)."""
    return int(round(float(degrees) / 90.0)) % 4


def display_rotation(degrees: float) -> int:
    """A display rotation in degrees -> the nearest of 0, 90, 180 and -90 (counter-clockwise)."""
    return (0, 90, 180, -90)[quarter_turns(degrees)]


def upright(rgb: np.ndarray, rotation: float) -> np.ndarray:
    """Turn a stored (H, W, C) frame as its display matrix says (``rotation``: counter-clockwise
    degrees, as PyAV's ``VideoFrame.rotation`` and FFmpeg's ``av_display_rotation_get`` give it;
    a phone clip tagged ``rotate=90`` has -90). Returns a contiguous array; (W, H, C) for odd
    quarter turns."""
    k = quarter_turns(rotation)
    return np.ascontiguousarray(np.rot90(rgb, k)) if k else rgb


def _frame_rotation(frame) -> float:
    try:
        return float(frame.rotation or 0)
    except (AttributeError, ValueError, TypeError):  # older PyAV, or a malformed matrix
        return 0.0


def probe(path: Path) -> VideoProbe:
    """Open ``path``, decode its first frame and describe the stream. Raises the decoder's own
    errors (``av.FFmpegError``, ``StopIteration`` for no frame, ``IndexError`` for no video
    stream); :func:`morf.capture.video.open_video` turns them into one-line input errors."""
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        first = next(container.decode(stream))
        rotation = _frame_rotation(first)
        k = quarter_turns(rotation)
        w, h = (first.height, first.width) if k % 2 else (first.width, first.height)
        rate = stream.average_rate or stream.guessed_rate
        fps = float(rate) if rate and 0 < float(rate) < 1000 else None
        count = int(stream.frames or 0)
        if count <= 0 and fps:  # Matroska / WebM state no frame count: estimate it as OpenCV does
            if stream.duration and stream.time_base:
                count = int(round(float(stream.duration * stream.time_base) * fps))
            elif container.duration:
                count = int(round(container.duration / av.time_base * fps))
        return VideoProbe(w, h, fps, count if count > 0 else None, display_rotation(rotation),
                          stream.codec_context.name)


def decode(path: Path, keep: Callable[[int], bool]) -> Iterator[DecodedFrame]:
    """Decode every frame of ``path`` in presentation order (stop early by closing the iterator).

    ``keep(index)`` says whether a frame's pixels are wanted (the others are decoded, as the
    codec needs them, but never converted to RGB). Times are relative to the first frame.
    Damaged data ends the stream (the caller notices the shortfall against the stated frame
    count); the error is not raised.
    """
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"  # frame threads: decoding is the slow part of ingesting
        t0 = None
        index = 0
        try:
            for frame in container.decode(stream):
                t = frame.time
                if t is not None:
                    t0 = t if t0 is None else t0
                    t = float(t - t0)
                rgb = None
                if keep(index):
                    rgb = upright(frame.to_ndarray(format="rgb24"), _frame_rotation(frame))
                yield DecodedFrame(index, t, rgb)
                index += 1
        except av.FFmpegError:
            return
