"""Frame sources: a video file, a folder of images, or one image, streamed frame by frame.

Frames are decoded one at a time (a minute of 1080p would not fit in memory), optionally
subsampled (``every``) and capped (``max_frames``). Every problem a user can cause (missing
file, not a video, no decodable frame, absurd resolution, unreadable image, frames of mixed
sizes) raises :class:`~morf.errors.InputError` with one line naming the file.

Videos are decoded with PyAV when it is installed (:mod:`morf.capture.video_pyav`): every frame
then carries its presentation time (variable frame rate clips keep their real timing) and is
turned upright as the container's display matrix says. Without PyAV, OpenCV decodes (it turns
frames upright itself where its FFmpeg build reads the rotation; frame times are then unknown).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from morf.capture.video_pyav import display_rotation
from morf.errors import InputError
from morf.io import read_image

# FFmpeg prints a line per damaged packet; the summary warning says it once instead. Read by
# OpenCV when its FFmpeg backend first starts, so set before any capture opens.
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")

IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
MIN_SIDE = 32  # smaller frames cannot show a person well enough to fit a body
MAX_SIDE = 8192  # larger frames are accepted only with a resize


@dataclass(frozen=True)
class SourceFrame:
    """One decoded frame.

    Fields:
        index: position in the source (0-based, counting every frame, kept or not).
        name: the image file's stem, or "" for video frames.
        rgb: (H, W, 3) uint8 at the source's own resolution, upright.
        time: seconds since the video's first frame (its presentation time stamp); None for
            images and for videos decoded without PyAV.
    """

    index: int
    name: str
    rgb: np.ndarray
    time: float | None = None


@dataclass
class FrameSource:
    """An opened source. ``frame_count`` is exact for images and an estimate for video
    (container metadata); ``decoded`` and ``warnings`` fill in while frames are read."""

    kind: str  # "video" | "images" | "image"
    path: Path
    width: int
    height: int
    fps: float | None
    frame_count: int | None
    files: tuple[Path, ...] = ()  # image files in order (images / image)
    decoder: str = ""  # "pyav" | "opencv" for videos
    rotation: int = 0  # counter-clockwise degrees the stored video frames were turned to stand upright
    decoded: int = 0  # frames decoded so far
    ended_early: bool = False  # the video stopped before its stated length
    warnings: list[str] = field(default_factory=list)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.stem for f in self.files)

    def frames(self, every: int = 1, max_frames: int | None = None) -> Iterator[SourceFrame]:
        """Yield every ``every``-th frame, at most ``max_frames`` of them."""
        if self.kind == "video":
            yield from self._video_frames(every, max_frames)
        else:
            yield from self._image_frames(every, max_frames)

    def kept_indices(self, every: int = 1, max_frames: int | None = None) -> list[int] | None:
        """Source indices that :meth:`frames` will yield (None when the length is unknown)."""
        if self.frame_count is None:
            return None
        idx = list(range(0, self.frame_count, every))
        return idx[:max_frames] if max_frames else idx

    # ---- internals ----------------------------------------------------------------------
    def _image_frames(self, every: int, max_frames: int | None) -> Iterator[SourceFrame]:
        n = 0
        for i in range(0, len(self.files), every):
            if max_frames is not None and n >= max_frames:
                return
            rgb = read_image(self.files[i])
            if rgb.shape[:2] != (self.height, self.width):
                raise InputError(f"frames differ in size: {self.files[i].name} is {rgb.shape[1]}x{rgb.shape[0]}, "
                                 f"{self.files[0].name} is {self.width}x{self.height}")
            self.decoded = i + 1
            n += 1
            yield SourceFrame(i, self.files[i].stem, rgb)

    def _video_frames(self, every: int, max_frames: int | None) -> Iterator[SourceFrame]:
        if self.decoder == "pyav":
            yield from self._pyav_frames(every, max_frames)
            return
        cap = _open_capture(self.path)
        try:
            n, i = 0, 0
            while max_frames is None or n < max_frames:
                # grab() skips decoding work for frames that are not kept
                if not cap.grab():
                    break
                if i % every == 0:
                    ok, bgr = cap.retrieve()
                    if not ok or bgr is None:
                        break
                    if bgr.shape[:2] != (self.height, self.width):
                        self.warnings.append(f"frame {i} changes size to {bgr.shape[1]}x{bgr.shape[0]}; stopped there")
                        break
                    n += 1
                    yield SourceFrame(i, "", cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
                i += 1
                self.decoded = i
            else:
                return  # stopped by max_frames: the rest of the video is not read
            if self.frame_count and i < self.frame_count:
                self.ended_early = True
                self.warnings.append(f"{self.path.name}: only {i} of {self.frame_count} frames could be decoded "
                                     f"(truncated or damaged file); using those")
        finally:
            cap.release()

    def _pyav_frames(self, every: int, max_frames: int | None) -> Iterator[SourceFrame]:
        from morf.capture.video_pyav import decode

        n, i = 0, 0
        frames = decode(self.path, lambda j: j % every == 0)
        try:
            for frame in frames:
                if max_frames is not None and n >= max_frames:
                    return  # the rest of the video is not read
                i = frame.index + 1
                self.decoded = i
                if frame.rgb is None:
                    continue
                if frame.rgb.shape[:2] != (self.height, self.width):
                    self.warnings.append(f"frame {frame.index} changes size to {frame.rgb.shape[1]}x"
                                         f"{frame.rgb.shape[0]}; stopped there")
                    return
                n += 1
                yield SourceFrame(frame.index, "", frame.rgb, frame.time)
        finally:
            frames.close()
        if self.frame_count and i < self.frame_count:
            self.ended_early = True
            self.warnings.append(f"{self.path.name}: only {i} of {self.frame_count} frames could be decoded "
                                 f"(truncated or damaged file); using those")


def natural_key(name: str) -> list:
    """Sort key that orders "f2" before "f10"."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", name)]


def check_size(width: int, height: int, what: str, resize: int | None) -> None:
    if min(width, height) < MIN_SIDE:
        raise InputError(f"{what} is {width}x{height}; frames must be at least {MIN_SIDE} px on each side")
    if max(width, height) > MAX_SIDE and resize is None:
        raise InputError(f"{what} is {width}x{height}, larger than {MAX_SIDE} px; pass --resize PX to scale it down")


def _open_capture(path: Path) -> cv2.VideoCapture:
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        cap.release()
        raise InputError(f"not a readable video: {path} (unknown format, damaged, or empty)")
    return cap


def open_video(path: str | os.PathLike, resize: int | None = None) -> FrameSource:
    """Open a video file and check that a first frame decodes (with PyAV when installed)."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"video not found: {path}")
    if not path.is_file():
        raise InputError(f"not a video file: {path}")
    source = _open_pyav(path)
    if source is None:
        source = _open_opencv(path)
    check_size(source.width, source.height, f"video {path.name}", resize)
    return source


def _open_pyav(path: Path) -> FrameSource | None:
    """The video through PyAV; None without PyAV or when FFmpeg cannot open it (OpenCV then tries,
    and words the error)."""
    from morf.capture.video_pyav import probe, pyav_available

    if not pyav_available():
        return None
    import av

    try:
        info = probe(path)
    except (av.FFmpegError, StopIteration, IndexError, ValueError):
        return None
    return FrameSource("video", path, info.width, info.height, info.fps, info.frame_count, decoder="pyav",
                       rotation=info.rotation)


def _open_opencv(path: Path) -> FrameSource:
    cap = _open_capture(path)
    try:
        ok, bgr = cap.read()
        if not ok or bgr is None:
            raise InputError(f"no frames could be decoded from {path} (empty or damaged video)")
        fps = cap.get(cv2.CAP_PROP_FPS)
        count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        # OpenCV's FFmpeg backend turns frames upright itself; its figure is clockwise degrees
        turned = -int(cap.get(cv2.CAP_PROP_ORIENTATION_META)) if cap.get(cv2.CAP_PROP_ORIENTATION_AUTO) else 0
    finally:
        cap.release()
    h, w = bgr.shape[:2]
    return FrameSource("video", path, w, h, float(fps) if fps and 0 < fps < 1000 else None,
                       count if count > 0 else None, decoder="opencv",
                       rotation=display_rotation(turned))


def open_images(path: str | os.PathLike, resize: int | None = None) -> FrameSource:
    """Open a folder of images (sorted by name, numbers in order) or a single image file."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"frames not found: {path}")
    if path.is_dir():
        files = sorted((p for p in path.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_EXTS
                        and not p.name.startswith(".")), key=lambda p: natural_key(p.name))
        if not files:
            raise InputError(f"no images ({', '.join(IMAGE_EXTS)}) in {path}")
        kind = "images"
    else:
        if path.suffix.lower() not in IMAGE_EXTS:
            raise InputError(f"not an image file: {path} (use --video for videos)")
        files, kind = [path], "image"
    first = read_image(files[0])
    h, w = first.shape[:2]
    check_size(w, h, f"image {files[0].name}", resize)
    return FrameSource(kind, path, w, h, None, len(files), tuple(files))


def exif_focal_px(path: Path, width: int, height: int) -> float | None:
    """Focal length in pixels from an image's EXIF 35 mm-equivalent focal length, if present."""
    try:
        from PIL import Image

        with Image.open(path) as im:
            exif = im.getexif().get_ifd(0x8769)  # the Exif sub-IFD holds the focal length
        f35 = float(exif.get(0xA405) or 0)  # FocalLengthIn35mmFilm
    except Exception:  # no or unreadable EXIF simply means "unknown"
        return None
    if f35 <= 0:
        return None
    # 35 mm equivalence is defined on the diagonal (43.27 mm for a 36 x 24 mm frame)
    return f35 * float(np.hypot(width, height)) / 43.27
