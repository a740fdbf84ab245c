"""SMPL / SMPL-X parameter files split by body part, laid out as the public ones are (same keys,
shapes and dtypes), all holding the body motion of :func:`motion_files.smpl_body_motion` so that
they can be compared with the AMASS files of ``tests/motion_files.py``:

- avatar projects' SMPL sequences (InstantAvatar's and Anim-NeRF's People-Snapshot ``poses.npz``):
  ``betas`` (1, 10), ``global_orient`` (T, 3), ``body_pose`` (T, 69), ``transl`` (T, 3), float32,
  no frame rate;
- SMPL-X as the ``smplx`` package's forward pass takes it (and estimators that write it save it):
  ``betas``, ``global_orient``, ``body_pose`` (T, 63), ``jaw_pose``, ``leye_pose``, ``reye_pose``
  (T, 3), ``left_hand_pose`` / ``right_hand_pose`` (T, 45), ``expression`` (T, 10), ``transl``;
- image-based estimators' rotation matrices (4D-Humans / HMR 2.0 ``pred_smpl_params``):
  ``global_orient`` (T, 1, 3, 3), ``body_pose`` (T, 23, 3, 3), ``betas`` (T, 10), no translation;
- a single-image fit (SMPLify-X results): every array with a batch axis of one, PCA hand poses
  ``left_hand_pose`` (1, 12).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.motion.so3 import rotvec_to_matrix
from motion_files import CAMERA_R, smpl_body_motion
from morf.motion.amass import SMPL_REST


def hand_motion(T: int, seed: int = 5) -> np.ndarray:
    """(T, 90) both hands' 30 joints (left hand first, MANO order), curling and spreading."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, T)[:, None]
    return rng.normal(scale=0.3, size=90) * np.sin(np.pi * t)


def camera_space(body: np.ndarray, trans: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Z-up motion as a video estimate stores it: in the camera's world (Y down, Z forward)."""
    from morf.motion.so3 import matrix_to_rotvec

    body = body.copy()
    body[:, :3] = matrix_to_rotvec(CAMERA_R @ rotvec_to_matrix(body[:, :3]))
    pelvis = (trans + SMPL_REST[0]) @ CAMERA_R.T
    return body, pelvis - SMPL_REST[0]


def write_smpl_params(path: Path, T: int = 24, dtype=np.float32, camera: bool = False, **extra) -> Path:
    """The avatar projects' SMPL layout; ``camera``: in a camera's Y-down world as estimates are."""
    body, trans = smpl_body_motion(T)
    if camera:
        body, trans = camera_space(body, trans)
    body_pose = np.concatenate([body[:, 3:], np.zeros((T, 6))], axis=1)  # + SMPL's two hand joints
    np.savez(path, betas=np.zeros((1, 10), dtype), global_orient=body[:, :3].astype(dtype),
             body_pose=body_pose.astype(dtype), transl=trans.astype(dtype), **extra)
    return path


def write_smplx_params(path: Path, T: int = 24, dtype=np.float32, hands: np.ndarray | None = None,
                       jaw: np.ndarray | None = None, **extra) -> Path:
    """The ``smplx`` forward-pass layout of SMPL-X; ``hands`` (T, 90) as in AMASS's ``pose_hand``."""
    body, trans = smpl_body_motion(T)
    hands = np.zeros((T, 90)) if hands is None else hands
    z3 = np.zeros((T, 3), dtype)
    arrays = dict(betas=np.zeros((1, 10), dtype), global_orient=body[:, :3], body_pose=body[:, 3:],
                  jaw_pose=z3 if jaw is None else jaw, leye_pose=z3, reye_pose=z3, left_hand_pose=hands[:, :45],
                  right_hand_pose=hands[:, 45:], expression=np.zeros((T, 10)), transl=trans)
    np.savez(path, **{k: np.asarray(v, dtype) for k, v in arrays.items()}, **extra)
    return path


def write_smpl_matrices(path: Path, T: int = 24) -> Path:
    """The estimators' rotation-matrix layout (no translation: in place)."""
    body, _ = smpl_body_motion(T)
    mats = rotvec_to_matrix(np.concatenate([body, np.zeros((T, 6))], axis=1).reshape(T, 24, 3))
    np.savez(path, global_orient=mats[:, :1].astype(np.float32), body_pose=mats[:, 1:].astype(np.float32),
             betas=np.zeros((T, 10), np.float32))
    return path


def write_single_fit(path: Path, frame: int = 5, pca: int = 12) -> Path:
    """One frame of the motion as a single-image SMPL-X fit stores it, with PCA hand poses."""
    body, trans = smpl_body_motion(24)
    f = slice(frame, frame + 1)
    np.savez(path, global_orient=body[f, :3].astype(np.float32), body_pose=body[f, 3:].astype(np.float32),
             left_hand_pose=np.full((1, pca), 0.3, np.float32), right_hand_pose=np.full((1, pca), 0.3, np.float32),
             jaw_pose=np.zeros((1, 3), np.float32), expression=np.zeros((1, 10), np.float32),
             betas=np.zeros((1, 10), np.float32), transl=trans[f].astype(np.float32))
    return path
