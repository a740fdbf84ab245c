"""Pairing side files (OpenPose JSON, mask images) with source frames.

Rules, tried in order; the first that covers every frame wins:

1. **By name** (image folders): ``img_07.png`` pairs with ``img_07.json``,
   ``img_07_keypoints.json`` or ``img_07_mask.png``.
2. **By frame number**: the last number in each file name is the source frame index
   (OpenPose writes ``video_000000000012_keypoints.json`` for frame 12); for image folders,
   the number in the image name.
3. **By sorted order**: the i-th file (names sorted with numbers in order) is source frame i;
   then the file count must equal the frame count.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from morf.capture.video import natural_key
from morf.errors import InputError

_SUFFIXES = ("_keypoints", "-keypoints", "_mask", "-mask", "_alpha", "_seg")


@dataclass(frozen=True)
class FileMatch:
    """How side files pair with frames: ``files[source_index]``, and the rule used."""

    files: dict[int, Path]
    rule: str  # "name" | "number" | "order"
    total: int  # files offered
    what: str  # "mask" | "OpenPose", for messages

    def get(self, index: int) -> Path:
        """The file for source frame ``index``."""
        try:
            return self.files[index]
        except KeyError:
            raise InputError(f"no {self.what} file for frame {index} (matched by {self.rule}; "
                             f"{self.total} {self.what} files)") from None


def list_files(path: Path, exts: tuple[str, ...], what: str) -> list[Path]:
    """A folder's files with one of ``exts`` (sorted naturally), or a single such file."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{what} not found: {path}")
    if path.is_file():
        if path.suffix.lower() not in exts:
            raise InputError(f"{what} {path} is not a {'/'.join(exts)} file")
        return [path]
    files = sorted((p for p in path.iterdir() if p.is_file() and p.suffix.lower() in exts and not p.name.startswith(".")),
                   key=lambda p: natural_key(p.name))
    if not files:
        raise InputError(f"no {'/'.join(exts)} files in {what} folder {path}")
    return files


def _strip(stem: str) -> str:
    for s in _SUFFIXES:
        if stem.endswith(s):
            return stem[: -len(s)]
    return stem


def _last_number(stem: str) -> int | None:
    nums = re.findall(r"\d+", stem)
    return int(nums[-1]) if nums else None


def count_mismatch(files: int, what: str, frames: int) -> InputError:
    """The error for side files (keypoints, masks) that do not number the frames."""
    return InputError(f"{frames} frames but {files} {what} files: one {what} file is needed for each frame (in name "
                      f"order, or named with the frame's number); add the missing ones or remove the extra ones")


def match_files(files: list[Path], wanted: list[int], frame_names: tuple[str, ...] | None,
                total_frames: int | None, what: str) -> FileMatch:
    """Pair ``files`` with source frames; every index in ``wanted`` must get a file.

    Args:
        files: candidate files, sorted naturally.
        wanted: source frame indices that need a file (may be empty when not known yet).
        frame_names: image stems of every source frame (image sources), or None (video).
        total_frames: frames in the source when known exactly (for the count check).
        what: "mask" or "OpenPose" (for messages).
    """
    if frame_names is not None:
        by_stem = {_strip(f.stem): f for f in files}
        by_stem.update({f.stem: f for f in files})
        if all(frame_names[i] in by_stem for i in wanted):
            mapping = {i: by_stem[s] for i, s in enumerate(frame_names) if s in by_stem}
            if mapping:
                return FileMatch(mapping, "name", len(files), what)
    numbers = [_last_number(f.stem) for f in files]
    if None not in numbers and len(set(numbers)) == len(numbers):
        by_num = dict(zip(numbers, files))
        if frame_names is None:
            mapping = by_num
        else:
            keys = {i: _last_number(s) for i, s in enumerate(frame_names)}
            mapping = {i: by_num[k] for i, k in keys.items() if k is not None and k in by_num}
        if all(i in mapping for i in wanted) and (wanted or frame_names is None):
            return FileMatch(mapping, "number", len(files), what)
    if total_frames is not None and len(files) != total_frames:
        raise count_mismatch(len(files), what, total_frames)
    match = FileMatch(dict(enumerate(files)), "order", len(files), what)
    for i in wanted:
        match.get(i)
    return match
