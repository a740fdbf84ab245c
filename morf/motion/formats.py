"""Which kind of motion an .npz holds, told by its arrays (never by its name).

=========  ================================================================================
kind       arrays
=========  ================================================================================
clip       ``morf_motion_version``, ``rotvecs`` (T, J, 3), ``transl`` (T, 3), ``fps``
           (:func:`morf.motion.clip.save_clip`)
player     ``rotvecs`` (T, J, 3), ``transl`` (T, 3), optional ``fps``: Anny poses as they are
fits       a capture's ``fits/fits.npz``: ``rotvecs``, ``transl``, ``shape``,
           ``keypoint_residual_px``, ... (:mod:`morf.fitting.fits_io`)
amass      ``poses`` (T, 156) SMPL-H or (T, 165) SMPL-X (or ``root_orient`` + ``pose_body``),
           ``trans``, ``mocap_framerate`` / ``mocap_frame_rate`` (:mod:`morf.motion.amass`)
smpl       ``poses`` (T, 72) + ``trans``, or AIST++ ``smpl_poses`` (T, 72) + ``smpl_trans``
           (+ ``smpl_scaling``) (:mod:`morf.motion.smpl`)
smpl-      SMPL / SMPL-X split by body part: ``global_orient`` (T, 3), ``body_pose`` (T, 69) or
params     (T, 63), ``transl``, ``betas``, SMPL-X hands and face (:mod:`morf.motion.smpl_params`)
=========  ================================================================================
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.fitting.fits_io import FITS_ONLY_KEYS  # torch-free, like this module
from morf.motion.amass import stored_fps
from morf.motion.checks import check_pose_arrays, numbers
from morf.motion.clip import MotionClip
from morf.motion.smpl_params import is_smpl_params

# What a motion .npz is expected to hold, for one-line errors.
EXPECTED_NPZ = ("a MoRF clip (rotvecs (T,J,3), transl (T,3), fps), AMASS SMPL-H / SMPL-X (poses (T,156) / "
                "(T,165), trans), SMPL / AIST++ (poses or smpl_poses (T,72), trans or smpl_trans), "
                "SMPL / SMPL-X parameters (global_orient (T,3), body_pose (T,69) or (T,63), transl) "
                "or a capture's fits/fits.npz")


def npz_motion_kind(arrays: dict[str, np.ndarray]) -> str | None:
    """"clip", "player", "fits", "amass", "smpl", "smpl-params" (see the module docstring) or None."""
    keys = set(arrays)
    if "morf_motion_version" in keys:
        return "clip"
    if {"rotvecs", "transl"} <= keys:
        return "fits" if any(k in keys for k in FITS_ONLY_KEYS) else "player"
    if is_smpl_params(arrays):
        return "smpl-params"
    if "smpl_poses" in keys:
        return "smpl"
    poses = arrays.get("poses")
    if poses is not None:
        return "smpl" if poses.ndim == 2 and poses.shape[1] == 72 else "amass"
    if {"root_orient", "pose_body"} <= keys:
        return "amass"
    return None


def describe_arrays(arrays: dict[str, np.ndarray], limit: int = 8) -> str:
    """``name (shape), ...`` of the first ``limit`` arrays, for messages."""
    if not arrays:
        return "no arrays"
    parts = [f"{k} {tuple(v.shape)}" for k, v in list(arrays.items())[:limit]]
    more = len(arrays) - limit
    return ", ".join(parts) + (f" and {more} more" if more > 0 else "")


def not_a_motion(path: Path, arrays: dict[str, np.ndarray]) -> InputError:
    """The one-line error for an .npz that is no motion of a known kind."""
    return InputError(f"{path}: not a motion: found {describe_arrays(arrays)}; expected {EXPECTED_NPZ}")


def player_clip(path: Path, arrays: dict[str, np.ndarray], fps: float | None = None) -> MotionClip:
    """A ``player`` .npz (Anny poses as they are) as a clip; ``fps`` when it stores none (else 30)."""
    rotvecs, transl = numbers(arrays, "rotvecs", str(path)), numbers(arrays, "transl", str(path))
    rate = check_pose_arrays(rotvecs, transl, stored_fps(arrays, path) or fps or 30.0, str(path))
    return MotionClip(rotvecs.astype(np.float32), transl.astype(np.float32), rate, path.stem, f"npz:{path.name}")
