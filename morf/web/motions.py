"""Motions for the page: every motion file the player reads, retargeted onto the avatar's body,
resampled to the page's frame rate and written as raw float32 frames.

``motions/NAME.bin``: (T, J * 3 + 3) float32 little-endian, per frame the (J, 3) axis-angle pose
("local-ref", bone 0 = the root's orientation) then the (3,) root translation in metres. The page
turns each frame into bone matrices itself (forward kinematics), so a motion costs 1.3 kB a frame.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.errors import InputError

FPS = 30.0  # the page's motion rate (a motion is resampled to it)
MAX_SECONDS = 120.0  # longer motions are cut: a web folder stays small


@dataclass(frozen=True)
class MotionSource:
    """A motion to put into the folder: ``name`` (a single file name, checked) and its file."""

    name: str
    path: Path


def shipped_motions() -> list[MotionSource]:
    """The motions shipped with morf (``resources/motions``)."""
    from morf.motion.library import motion_library

    return [MotionSource(name, path) for name, path in motion_library() if "/" not in name]


def motion_sources(user_paths: list[str] | None) -> list[MotionSource]:
    """The shipped motions, then each user file (named by its file name without suffix); a one-line
    error for a missing file or two motions of one name."""
    from morf.io.names import check_name

    sources = shipped_motions()
    for p in user_paths or []:
        path = Path(p).expanduser()
        if not path.is_file():
            raise InputError(f"motion file not found: {p}" if not path.is_dir() else
                             f"{p} is a folder, not a motion file; give one .bvh or .npz file per --motion")
        name = check_name(path.stem, "motion name")
        if any(s.name == name for s in sources):
            raise InputError(f"two motions are named {name!r} (--motion {p}); rename the file")
        sources.append(MotionSource(name, path))
    return sources


def write_motions(sources: list[MotionSource], folder: Path, num_bones: int, shape: list[float] | None,
                  command: str, source_fps: float | None = None) -> list[dict]:
    """Retarget, resample and write each motion into ``folder`` (``source_fps``: the rate of files
    that store none); returns avatar.json's motion
    entries: {"name", "file", "frames", "fps", "bones", "centre": the median root translation}."""
    from morf.motion.clip import resample
    from morf.playback.motion_input import load_playback_motion

    def body_shape():
        import torch

        return None if shape is None else torch.tensor([shape], dtype=torch.float32)

    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for src in sources:
        clip = resample(load_playback_motion(src.path, num_bones, body_shape, source_fps), FPS)
        for note in clip.notes:
            print(f"{command}: note: {src.name}: {note}", file=sys.stderr)
        frames = min(clip.num_frames, int(MAX_SECONDS * FPS))
        rot, tr = clip.rotvecs[:frames].reshape(frames, -1), clip.transl[:frames]
        data = np.ascontiguousarray(np.concatenate([rot, tr], axis=1), "<f4")
        if not np.isfinite(data).all():
            raise InputError(f"{src.path}: the motion holds NaN or inf after retargeting; check the file")
        (folder / f"{src.name}.bin").write_bytes(data.tobytes())
        entries.append({"name": src.name, "file": f"motions/{src.name}.bin", "frames": frames, "fps": FPS,
                        "bones": num_bones, "centre": [round(float(v), 5) for v in np.median(tr, axis=0)]})
    return entries
