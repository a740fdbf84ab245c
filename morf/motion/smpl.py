"""SMPL pose sequences on the 24-joint SMPL body (``(T, 72)`` axis-angle), as .npz:

- AIST++ layout: ``smpl_poses`` (T, 72), ``smpl_trans`` (T, 3), optional ``smpl_scaling`` (1,)
  (translations are divided by it, giving metres); no frame rate is stored: AIST++ is 60 fps;
- plain SMPL: ``poses`` (T, 72), ``trans`` (T, 3) (optional: in place), optionally a frame rate
  under one of :data:`morf.motion.amass.FPS_KEYS`; 30 fps when it stores none.

Such files come from several sources with different world axes (AIST++ and most SMPL tools Y up,
AMASS Z up, camera-space estimates Y down), so the up axis is found from the data: the world axis
along which the pelvis's own up axis points on most frames. The two hand joints (22, 23) are
not used.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.motion.amass import SMPL_REST, smpl_source_motion, stored_fps
from morf.motion.checks import check_rotvecs, check_translations, numbers
from morf.motion.skeleton import SourceMotion
from morf.motion.so3 import matrix_to_rotvec, rotvec_to_matrix

AIST_FPS = 60.0  # AIST++ motions are 60 fps and store no rate
SMPL_DEFAULT_FPS = 30.0  # other SMPL sequences that store no rate


def world_up(root_rotvecs: np.ndarray) -> tuple[str, int]:
    """(axis, sign) of the world's up direction, from (T, 3) SMPL root rotations.

    The SMPL rest body is Y up, so R_root @ (0, 1, 0) is the pelvis's up direction; its median
    over frames points along the world's up axis for anyone mostly upright.
    """
    up = np.median(rotvec_to_matrix(root_rotvecs)[:, :, 1], axis=0)
    k = int(np.argmax(np.abs(up[1:]))) + 1  # Y or Z: no motion file stands people along X
    return "yz"[k - 1], 1 if up[k] >= 0 else -1


def read_smpl(path: str | Path, arrays: dict[str, np.ndarray], fps: float | None = None) -> SourceMotion:
    """An AIST++ or plain SMPL .npz (see the module docstring) as a :class:`SourceMotion`.

    ``fps`` is used when the file stores no frame rate (default: 60 for AIST++, else 30).
    Raises:
        InputError: missing arrays or wrong shapes.
    """
    path = Path(path)
    aist = "smpl_poses" in arrays
    pose_key, trans_key = ("smpl_poses", "smpl_trans") if aist else ("poses", "trans")
    poses = numbers(arrays, pose_key, str(path))
    if poses.ndim != 2 or poses.shape[1] != 72:
        raise InputError(f"{path}: '{pose_key}' has shape {poses.shape}; expected (T, 72) SMPL")
    check_rotvecs(poses, str(path), f"'{pose_key}'")
    T = poses.shape[0]
    if aist and trans_key not in arrays:
        raise InputError(f"{path}: AIST++ motion without 'smpl_trans'")
    trans = numbers(arrays, trans_key, str(path), np.zeros((T, 3)))
    trans_field = f"'{trans_key}'"
    if aist and "smpl_scaling" in arrays:
        scaling = numbers(arrays, "smpl_scaling", str(path)).reshape(-1)
        if scaling.size == 0 or not np.isfinite(scaling[0]) or scaling[0] <= 0:
            raise InputError(f"{path}: 'smpl_scaling' is {scaling[:1].tolist() or 'empty'}; expected a positive "
                             "number (translations are divided by it)")
        with np.errstate(over="ignore"):  # a tiny scaling gives inf, refused below
            trans = trans / scaling[0]
        trans_field += " divided by 'smpl_scaling'"
    if trans.shape == (T, 3):
        check_translations(trans, str(path), trans_field)
    rate = stored_fps(arrays, path) or fps or (AIST_FPS if aist else SMPL_DEFAULT_FPS)
    body, trans, axis = upright(poses[:, :66], trans)
    layout = "aist++" if aist else "smpl"
    return smpl_source_motion(body, trans, rate, axis, path, f"{layout}:{path.name} ({axis}-up)", "smpl")


def upright(body: np.ndarray, trans: np.ndarray) -> tuple[np.ndarray, np.ndarray, str]:
    """(body, trans, up axis) of a SMPL motion in a world of unknown axes: the up axis found by
    :func:`world_up`, and an upside-down world (camera space, Y down) turned half a turn about X.

    Args: body (T, 66) axis-angle, root first; trans (T, 3) metres. The arrays are not changed.
    A translation of the wrong shape is passed on as it is (the caller reports it).
    """
    T = body.shape[0]
    body = body.copy()
    if not (T and trans.shape == (T, 3)):
        return body, trans, "y"
    axis, sign = world_up(body[:, :3])
    if sign < 0:
        flip = np.diag([1.0, -1.0, -1.0])
        body[:, :3] = matrix_to_rotvec(flip @ rotvec_to_matrix(body[:, :3]))
        trans = (trans + SMPL_REST[0]) @ flip.T - SMPL_REST[0]
    return body, trans, axis
