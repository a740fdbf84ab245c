"""Motions for playback: every motion file :func:`morf.motion.load_motion` reads, as Anny poses."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.errors import InputError


@dataclass(frozen=True)
class PlaybackMotion:
    """Poses to play.

    Fields:
        rotvecs: (T, J, 3) float32 axis-angle per bone (Anny "local-ref"); transl: (T, 3) float32; fps: frames/s.
    """

    rotvecs: np.ndarray
    transl: np.ndarray
    fps: float

    @property
    def num_frames(self) -> int:
        return int(self.rotvecs.shape[0])


def load_playback_motion(path: str | Path, num_bones: int, shape=None, source_fps: float | None = None) -> PlaybackMotion:
    """Read any motion :func:`morf.motion.load_motion` reads (detected by content: Anny poses
    ``rotvecs`` (T, J, 3) + ``transl`` (T, 3) + ``fps``, MoRF clips, AMASS SMPL-H / SMPL-X,
    AIST++ / SMPL, a capture's ``fits/fits.npz``, BVH), retargeted onto Anny with phenotype
    ``shape`` (1, 6) (default: Anny's default body). ``source_fps``: the rate of files that store none.

    Raises:
        InputError: unreadable, of no known kind, or not ``num_bones`` bones.
    """
    from morf.motion import load_motion

    path = Path(path)
    if not path.is_file():
        raise InputError(f"motion file not found: {path}")
    m = load_motion(path, shape=shape, source_fps=source_fps)
    clip = PlaybackMotion(np.asarray(m.rotvecs, np.float32), np.asarray(m.transl, np.float32), float(m.fps))
    T = clip.rotvecs.shape[0]
    if clip.rotvecs.ndim != 3 or clip.rotvecs.shape[1:] != (num_bones, 3) or clip.transl.shape != (T, 3) or T == 0:
        raise InputError(f"{path}: motion must be rotvecs (T, {num_bones}, 3) and transl (T, 3), "
                         f"got {clip.rotvecs.shape} and {clip.transl.shape}")
    return clip


def resample(clip: PlaybackMotion, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-frame resampling to ``fps`` (playback speed is kept): rotvecs (N, J, 3), transl (N, 3)."""
    duration = clip.num_frames / clip.fps
    n = max(1, int(round(duration * fps)))
    idx = np.minimum(np.round(np.arange(n) * clip.fps / fps).astype(int), clip.num_frames - 1)
    return clip.rotvecs[idx], clip.transl[idx]
