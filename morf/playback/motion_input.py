"""Motions for playback: every motion file :func:`morf.motion.load_motion` reads, as a
:class:`~morf.motion.clip.MotionClip` of Anny poses checked against the avatar's bones."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.motion.clip import MotionClip


def load_playback_motion(path: str | Path, num_bones: int, shape=None, source_fps: float | None = None) -> MotionClip:
    """Read any motion :func:`morf.motion.load_motion` reads (detected by content: Anny poses
    ``rotvecs`` (T, J, 3) + ``transl`` (T, 3) + ``fps``, MoRF clips, AMASS SMPL-H / SMPL-X,
    AIST++ / SMPL, SMPL / SMPL-X parameters split by body part (``global_orient``, ``body_pose``,
    ...), a capture's ``fits/fits.npz``, BVH), retargeted onto Anny with phenotype
    ``shape`` (1, 6) (default: Anny's default body; a function giving it is called only when the
    motion is retargeted). ``source_fps``: the rate of files that store none.

    Raises:
        InputError: unreadable, of no known kind, or not ``num_bones`` bones.
    """
    from morf.motion import load_motion

    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path} is a folder, not a motion file; give one .bvh or .npz file")
    if not path.is_file():
        raise InputError(f"motion file not found: {path}")
    m = load_motion(path, shape=shape, source_fps=source_fps)
    clip = replace(m, rotvecs=np.asarray(m.rotvecs, np.float32), transl=np.asarray(m.transl, np.float32))
    if clip.rotvecs.shape[1] != num_bones or clip.num_frames == 0:
        raise InputError(f"{path}: motion must be rotvecs (T, {num_bones}, 3) and transl (T, 3), "
                         f"got {clip.rotvecs.shape} and {clip.transl.shape}")
    return clip
