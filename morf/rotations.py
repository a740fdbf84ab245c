"""Rotations in numpy, torch-free (the player's and the view colours' share)."""

from __future__ import annotations

import numpy as np


def rotvec_to_matrix_rodrigues(rotvecs: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle -> (..., 3, 3) rotation matrices (Rodrigues, safe at zero).

    The closed form, not scipy's :func:`morf.motion.so3.rotvec_to_matrix`: the two agree to about
    1e-15 but not bit for bit, and the player's and glTF's bone transforms are made with this one
    (:meth:`morf.export.skeleton.SkinningSkeleton.bone_transforms`), the view colours' orientations too.
    """
    r = np.asarray(rotvecs, np.float64)
    theta2 = (r * r).sum(-1)[..., None, None]
    theta = np.sqrt(theta2)
    small = theta2 < 1e-12
    a = np.where(small, 1 - theta2 / 6, np.sin(theta) / np.where(small, 1, theta))
    b = np.where(small, 0.5 - theta2 / 24, (1 - np.cos(theta)) / np.where(small, 1, theta2))
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    zero = np.zeros_like(x)
    K = np.stack([zero, -z, y, z, zero, -x, -y, x, zero], -1).reshape(*r.shape[:-1], 3, 3)
    return np.eye(3) + a * K + b * (K @ K)
