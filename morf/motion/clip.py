"""A motion in the body model's own pose parameters: what the player and the studio animate.

Numpy only at import, so the torch-free player can use it; torch is imported by the methods that
build :class:`~morf.body.model.BodyPose` batches.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from morf.errors import InputError
from morf.io import load_npz, save_npz
from morf.motion.checks import check_pose_arrays, numbers
from morf.motion.so3 import slerp_rotvecs

if TYPE_CHECKING:
    import torch

    from morf.body.model import BodyPose

CLIP_FORMAT_VERSION = 1


@dataclass(frozen=True)
class MotionClip:
    """A sequence of Anny poses.

    Fields:
        rotvecs: (T, J, 3) float32 axis-angle per Anny bone in the body model's own parameters
            (:class:`~morf.body.model.BodyPose`: "local-ref", world-aligned axes about each
            bone's head, composed after the parent's; bone 0 = root/global orientation).
        transl: (T, 3) float32 root translation, metres, Anny's world (Z up, person faces -Y).
        fps: frames per second.
        name: short name for pickers; source: where it came from (file, format, notes).
        notes: what the source held that the clip could not keep (a jaw rotation the body has
            no bone for), one sentence each: said to the user, never saved with the clip.
    """

    rotvecs: np.ndarray
    transl: np.ndarray
    fps: float
    name: str = ""
    source: str = ""
    notes: tuple[str, ...] = ()

    def __post_init__(self):
        r, t = np.asarray(self.rotvecs), np.asarray(self.transl)
        if r.ndim != 3 or r.shape[2] != 3 or t.shape != (r.shape[0], 3):
            raise ValueError(f"MotionClip wants rotvecs (T, J, 3) and transl (T, 3), got {r.shape} and {t.shape}")
        if not self.fps > 0:
            raise ValueError(f"MotionClip fps must be positive, got {self.fps}")

    @property
    def num_frames(self) -> int:
        return int(self.rotvecs.shape[0])

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame."""
        return (self.num_frames - 1) / self.fps

    def __len__(self) -> int:
        return self.num_frames

    def __getitem__(self, i: int) -> BodyPose:
        return self.pose(i)

    def pose(self, i: int, device: str | torch.device = "cpu") -> BodyPose:
        """Frame ``i`` (negative counts from the end) as a batch-1 :class:`BodyPose`, float32."""
        return self.poses(np.array([i]), device)

    def poses(self, frames: np.ndarray | slice, device: str | torch.device = "cpu") -> BodyPose:
        """Several frames as one batch: rotvecs (B, J, 3), transl (B, 3)."""
        import torch

        from morf.body.model import BodyPose

        r = torch.as_tensor(np.asarray(self.rotvecs[frames], dtype=np.float32), device=device)
        t = torch.as_tensor(np.asarray(self.transl[frames], dtype=np.float32), device=device)
        return BodyPose(r, t)

    def frame_at(self, seconds: float, loop: bool = True) -> int:
        """The frame shown at time ``seconds`` (wrapping round when ``loop``, else held at the end)."""
        i = int(np.floor(seconds * self.fps + 1e-6))
        return i % self.num_frames if loop else int(np.clip(i, 0, self.num_frames - 1))


def resample(clip: MotionClip, fps: float) -> MotionClip:
    """The clip at another frame rate over the same duration: slerp for rotations, linear for
    translation. Frames fall at k / fps for k = 0 .. floor(duration * fps)."""
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if clip.num_frames == 1 or abs(fps - clip.fps) < 1e-9:
        return replace(clip, fps=float(fps))
    rot, tr = at_uniform_times(clip.rotvecs, clip.transl, np.arange(clip.num_frames) / clip.fps, fps)
    return replace(clip, rotvecs=rot.astype(np.float32), transl=tr.astype(np.float32), fps=float(fps))


def at_uniform_times(rotvecs: np.ndarray, transl: np.ndarray, times: np.ndarray,
                     fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Poses recorded at ``times`` (seconds, increasing: a variable-frame-rate clip) sampled at
    ``times[0] + k / fps`` over the same span: slerp for rotations, linear for translation.

    Args: rotvecs (T, J, 3), transl (T, 3), times (T,). Returns (rotvecs, transl) at the new times.
    """
    t = np.asarray(times, np.float64)
    if t.shape != (len(rotvecs),) or not (np.diff(t) > 0).all():
        raise ValueError("times must be one increasing time per frame")
    n = int(np.floor((t[-1] - t[0]) * fps + 1e-6)) + 1
    new = t[0] + np.arange(n) / fps
    i1 = np.clip(np.searchsorted(t, new, side="right"), 1, len(t) - 1)
    i0 = i1 - 1
    w = np.clip((new - t[i0]) / (t[i1] - t[i0]), 0.0, 1.0)
    rot = slerp_rotvecs(np.asarray(rotvecs)[i0], np.asarray(rotvecs)[i1], w)
    tr = np.asarray(transl)[i0] * (1 - w)[:, None] + np.asarray(transl)[i1] * w[:, None]
    return rot, tr


def save_clip(clip: MotionClip, path: str | os.PathLike) -> None:
    """Write a clip as .npz (atomic, no pickle)."""
    save_npz(path, morf_motion_version=np.int32(CLIP_FORMAT_VERSION), rotvecs=clip.rotvecs.astype(np.float32),
             transl=clip.transl.astype(np.float32), fps=np.float64(clip.fps), name=np.str_(clip.name),
             source=np.str_(clip.source))


def clip_from_arrays(arrays: dict[str, np.ndarray], path: str | os.PathLike = "") -> MotionClip:
    """A clip from the arrays of a file written by :func:`save_clip`; InputError if they do not fit."""
    try:
        version = int(np.asarray(arrays.get("morf_motion_version", -1)).reshape(-1)[0])
    except (ValueError, TypeError, IndexError):
        version = -1
    if version != CLIP_FORMAT_VERSION:
        raise InputError(f"{path}: motion clip format version {version}; this build reads {CLIP_FORMAT_VERSION}")
    origin = str(path)
    rotvecs, transl = numbers(arrays, "rotvecs", origin), numbers(arrays, "transl", origin)
    fps = numbers(arrays, "fps", origin).reshape(-1)
    if fps.size != 1:
        raise InputError(f"{path}: 'fps' holds {fps.size} values; expected one frame rate")
    rate = check_pose_arrays(rotvecs, transl, fps[0], origin, ("'rotvecs'", "'transl'", "'fps'"))
    return MotionClip(rotvecs.astype(np.float32), transl.astype(np.float32), rate,
                      str(arrays.get("name", Path(path).stem)), str(arrays.get("source", "")))


def load_clip(path: str | os.PathLike) -> MotionClip:
    """Read a clip written by :func:`save_clip`."""
    return clip_from_arrays(load_npz(path, error=InputError), path)
