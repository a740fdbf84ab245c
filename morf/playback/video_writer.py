"""Video encoders for rendered frames: H.264 or VP9 through PyAV, MPEG-4 Part 2 through OpenCV.

Browsers play H.264 in .mp4 (yuv420p) and VP9 in .webm, not the MPEG-4 Part 2 ("mp4v") that
OpenCV's own writer makes. With PyAV installed (``pip install av``, the ``video`` extra) .mp4 /
.m4v / .mov get H.264 and .webm gets VP9, both tagged BT.709 (the conversion from RGB uses that
matrix, so every player turns them back into the same colours) and, for .mp4, with the index at
the front so a browser starts playing before the whole file has arrived. Without PyAV, .mp4 /
.m4v / .mov fall back to OpenCV's mp4v, as before, and .webm is refused with one line.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np

from morf.errors import InputError

MP4_SUFFIXES = (".mp4", ".m4v", ".mov")
VIDEO_SUFFIXES = MP4_SUFFIXES + (".webm",)
BT709 = 1  # FFmpeg's AVCOL_SPC_BT709 = AVCOL_PRI_BT709 = AVCOL_TRC_BT709
LIMITED_RANGE = 1  # AVCOL_RANGE_MPEG: 16-235, what players expect of yuv420p video


@dataclass(frozen=True)
class Codec:
    """An encoder choice. ``encoder``: FFmpeg's name (or "mp4v" for OpenCV); ``label``: what the
    user is told; ``options``: encoder options."""

    encoder: str
    label: str
    options: dict[str, str] = field(default_factory=dict)


H264 = Codec("libx264", "H.264", {"crf": "18", "preset": "fast"})
# constant quality (b:v 0), row threads; cpu-used 5 trades a little size for speed
VP9 = Codec("libvpx-vp9", "VP9", {"crf": "30", "b:v": "0", "cpu-used": "5", "row-mt": "1"})
MP4V = Codec("mp4v", "MPEG-4 Part 2 (mp4v; browsers play H.264: pip install av)")


def pyav_encoder(name: str) -> bool:
    """Whether PyAV is installed and its FFmpeg has the encoder ``name``."""
    try:
        import av

        av.codec.Codec(name, "w")
    except Exception:  # ImportError, or av's UnknownCodecError
        return False
    return True


def choose_codec(path: str | Path) -> Codec:
    """The codec a video at ``path`` is written with (by its suffix and what is installed)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".webm":
        if not pyav_encoder(VP9.encoder):
            raise InputError(f"writing {Path(path).name} (VP9 .webm) needs PyAV: pip install av; or write a .mp4")
        return VP9
    if suffix in MP4_SUFFIXES:
        return H264 if pyav_encoder(H264.encoder) else MP4V
    raise InputError(f"not a video file name: {path} (use {', '.join(VIDEO_SUFFIXES)})")


def even_size(rgb: np.ndarray) -> np.ndarray:
    """Pad an (H, W, 3) frame by repeating its last row / column to an even size (4:2:0 chroma
    covers 2 x 2 pixels, so H.264 and VP9 in yuv420p need even sides)."""
    h, w = rgb.shape[:2]
    if h % 2 == 0 and w % 2 == 0:
        return rgb
    return np.pad(rgb, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")


class PyAVWriter:
    """(H, W, 3) uint8 RGB frames -> ``path`` with PyAV (H.264 or VP9, yuv420p, BT.709)."""

    def __init__(self, path: Path, fps: float, size: tuple[int, int], codec: Codec):
        import av

        self.codec = codec
        w, h = size
        options = {"movflags": "+faststart"} if path.suffix.lower() in MP4_SUFFIXES else {}
        try:
            self._container = av.open(str(path), "w", options=options)
            stream = self._container.add_stream(codec.encoder, rate=Fraction(fps).limit_denominator(100000))
        except av.FFmpegError as e:
            raise InputError(f"cannot open a video writer for {path}: {e}") from None
        stream.width, stream.height = w + w % 2, h + h % 2
        stream.pix_fmt = "yuv420p"
        stream.options = dict(codec.options)
        cc = stream.codec_context
        cc.colorspace, cc.color_primaries, cc.color_trc, cc.color_range = BT709, BT709, BT709, LIMITED_RANGE
        self._stream = stream

    def write(self, rgb: np.ndarray) -> None:
        import av

        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(even_size(rgb)), format="rgb24")
        frame = frame.reformat(format="yuv420p", dst_colorspace=BT709, dst_color_range=LIMITED_RANGE)
        frame.colorspace, frame.color_range = BT709, LIMITED_RANGE
        for packet in self._stream.encode(frame):
            self._container.mux(packet)

    def close(self) -> None:
        if self._container is None:
            return
        try:
            for packet in self._stream.encode():  # flush the encoder's delayed frames
                self._container.mux(packet)
        finally:
            self._container.close()
            self._container = None


class OpenCVWriter:
    """(H, W, 3) uint8 RGB frames -> ``path`` with OpenCV's mp4v writer (no PyAV)."""

    def __init__(self, path: Path, fps: float, size: tuple[int, int]):
        import cv2

        self.codec = MP4V
        self._writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), float(fps), tuple(size))
        if not self._writer.isOpened():
            raise InputError(f"cannot open a video writer for {path}")

    def write(self, rgb: np.ndarray) -> None:
        self._writer.write(np.ascontiguousarray(rgb[..., ::-1]))

    def close(self) -> None:
        self._writer.release()


def open_video_writer(path: str | Path, fps: float, size: tuple[int, int], codec: Codec | None = None):
    """A writer for ``path`` (``write(rgb)``, ``close()``, ``codec``); ``size`` is (width, height)."""
    path = Path(path)
    codec = codec or choose_codec(path)
    if codec is MP4V:
        return OpenCVWriter(path, fps, size)
    return PyAVWriter(path, fps, size, codec)
