"""Numbers read from motion files, checked where they enter: every reader (BVH, AMASS, AIST++ /
SMPL, fits, Anny poses, MoRF clips) and every user of a clip (the player, the glTF export) goes
through these, so one bad file is refused the same way by every command, with one line naming
the file, the field and the first bad frame.

NaN or infinite values would otherwise surface as blank frames, numpy warnings or a linear
algebra error deep inside retargeting; absurd ones (1e30) as a .glb full of them or a resample
to billions of frames. The ranges are wide: no person turns a joint a hundred times over, walks
a kilometre from the origin within a clip, or is filmed for longer than a working day.

Numpy only (the torch-free player reads motions).
"""

from __future__ import annotations

import math

import numpy as np

from morf.errors import InputError
from morf.io.arrays import first_outside

MAX_TURNS = 100
MAX_ANGLE_DEG = 360.0 * MAX_TURNS  # Euler angles (BVH), degrees
MAX_ANGLE_RAD = 2 * math.pi * MAX_TURNS  # axis-angle components, radians
MAX_TRANSLATION_M = 1000.0  # root translations and bone offsets, metres
MIN_FPS = 0.01  # a frame every 100 s
MAX_FPS = 10_000.0
MAX_DURATION_S = 8 * 3600.0
MAX_PHENOTYPE = 100.0  # body shape values (Anny's lie in [0, 1])


def number_text(v: float) -> str:
    """A value for messages: ``NaN``, ``inf``, ``-inf`` or ``%g``."""
    if math.isnan(v):
        return "NaN"
    return f"{v:g}" if math.isfinite(v) else ("inf" if v > 0 else "-inf")


def numbers(arrays: dict[str, np.ndarray], key: str, origin: str, default: np.ndarray | None = None) -> np.ndarray:
    """``arrays[key]`` as float64, InputError when it holds no numbers (text, say); ``default``
    (or an InputError naming the key) when it is absent."""
    if key not in arrays:
        if default is None:
            raise InputError(f"{origin}: no '{key}' array")
        return np.asarray(default, np.float64)
    a = np.asarray(arrays[key])
    if a.dtype.kind not in "biuf":
        raise InputError(f"{origin}: '{key}' holds {a.dtype} values, not numbers")
    return a.astype(np.float64)


def check_range(values: np.ndarray, origin: str, field: str, limit: float, unit: str, what: str,
                frame_axis: bool = True) -> None:
    """InputError unless every entry of ``values`` is finite and within +-``limit``.

    Args:
        origin: the file (or flag) the values came from; field: their name there (``'poses'``).
        unit: "rad", "deg", "m", ... as shown in the message ("" for none); what: "rotation", "translation", ...
        frame_axis: whether the first axis counts frames (the message names the first bad one).
    """
    bad = first_outside(values, -limit, limit)
    if bad is None:
        return
    index, v = bad
    shown = number_text(v) + (f" {unit}" if unit and math.isfinite(v) else "")
    rule = f"every {what} must be a finite number within +-{limit:g}" + (f" {unit}" if unit else "")
    if frame_axis and index:
        raise InputError(f"{origin}: {field} is {shown} at frame {index[0]}; {rule}: fix or cut that frame")
    raise InputError(f"{origin}: {field} is {shown}; {rule}")


def check_rotvecs(values: np.ndarray, origin: str, field: str) -> None:
    """Axis-angle rotations (radians), frames first."""
    check_range(values, origin, field, MAX_ANGLE_RAD, "rad", "rotation")


def check_degrees(values: np.ndarray, origin: str, field: str) -> None:
    """Euler angles (degrees, as BVH stores them), frames first."""
    check_range(values, origin, field, MAX_ANGLE_DEG, "deg", "rotation")


def check_translations(values: np.ndarray, origin: str, field: str) -> None:
    """Positions or translations in metres, frames first."""
    check_range(values, origin, field, MAX_TRANSLATION_M, "m", "translation")


def check_fps(fps: float, origin: str, field: str = "frame rate") -> float:
    """``fps`` as a float, InputError unless finite and in [MIN_FPS, MAX_FPS]."""
    try:
        fps = float(fps)
    except (TypeError, ValueError):
        raise InputError(f"{origin}: {field} is not a number") from None
    if not MIN_FPS <= fps <= MAX_FPS:  # NaN fails too
        raise InputError(f"{origin}: {field} is {number_text(fps)} fps; a motion's frame rate must be between "
                         f"{MIN_FPS:g} and {MAX_FPS:g} fps")
    return fps


def check_duration(num_frames: int, fps: float, origin: str) -> None:
    """InputError for a motion longer than MAX_DURATION_S (resampling it would not fit in memory)."""
    seconds = (num_frames - 1) / fps
    if seconds > MAX_DURATION_S:
        raise InputError(f"{origin}: {num_frames} frames at {fps:g} fps last {seconds / 3600:.1f} hours; a motion may "
                         f"last at most {MAX_DURATION_S / 3600:g} hours: check its frame rate, or cut it")


def check_pose_arrays(rotvecs: np.ndarray, transl: np.ndarray, fps: float, origin: str,
                      fields: tuple[str, str, str] = ("'rotvecs'", "'transl'", "frame rate")) -> float:
    """Anny poses as a motion file or a clip holds them: rotations (T, J, 3) radians, root
    translation (T, 3) metres, at least one frame, a frame rate; returns the rate as a float."""
    r, t = np.shape(rotvecs), np.shape(transl)
    if len(r) != 3 or r[2] != 3 or t != (r[0], 3) or r[0] == 0:
        raise InputError(f"{origin}: {fields[0]} has shape {r} and {fields[1]} {t}; expected (T, J, 3) and (T, 3) "
                         "with T >= 1 frames")
    check_rotvecs(rotvecs, origin, fields[0])
    check_translations(transl, origin, fields[1])
    fps = check_fps(fps, origin, fields[2])
    check_duration(r[0], fps, origin)
    return fps


def check_clip(clip, origin: str) -> None:
    """A :class:`~morf.motion.clip.MotionClip` before it is played or exported."""
    check_pose_arrays(clip.rotvecs, clip.transl, clip.fps, origin)


MAX_ROTATION_ERROR = 1e-2  # |R^T R - I| and |det R - 1| of a rotation matrix stored as float32 and rounded


def check_rotation_matrices(values: np.ndarray, origin: str, field: str) -> None:
    """(..., 3, 3) rotation matrices, frames first: finite, orthonormal and right-handed (to
    :data:`MAX_ROTATION_ERROR`); InputError naming the first frame that is not."""
    check_range(values, origin, field, 1.0 + MAX_ROTATION_ERROR, "", "rotation matrix entry")
    m = np.asarray(values, np.float64)
    gram = np.swapaxes(m, -1, -2) @ m - np.eye(3)
    bad = (np.abs(gram).max(axis=(-1, -2)) > MAX_ROTATION_ERROR) | (np.abs(np.linalg.det(m) - 1.0) > MAX_ROTATION_ERROR)
    if bad.any():
        where = f" at frame {np.argwhere(bad)[0][0]}" if bad.ndim else ""
        raise InputError(f"{origin}: {field} holds a 3x3 matrix that is not a rotation{where} (not orthonormal, or a "
                         "mirror); fix or cut that frame")
