"""Rotation helpers in numpy for motion data (batched over leading axes, float64).

The torch versions in :mod:`morf.body.rotations` serve differentiable fitting; motion files are
plain arrays, so these stay in numpy (scipy's Rotation does the conversions).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def rotvec_to_matrix(rotvec: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle -> (..., 3, 3)."""
    rotvec = np.asarray(rotvec, dtype=np.float64)
    flat = Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix()
    return flat.reshape(*rotvec.shape[:-1], 3, 3)


def matrix_to_rotvec(matrix: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices -> (..., 3) axis-angle with angle in [0, pi]."""
    matrix = np.asarray(matrix, dtype=np.float64)
    flat = Rotation.from_matrix(matrix.reshape(-1, 3, 3)).as_rotvec()
    return flat.reshape(*matrix.shape[:-2], 3)


def euler_to_matrix(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles (..., 3) in degrees, in channel ``order`` (e.g. "ZYX" as in BVH).

    R = R_order[0](a0) @ R_order[1](a1) @ R_order[2](a2), the BVH convention.
    """
    angles_deg = np.asarray(angles_deg, dtype=np.float64)
    flat = Rotation.from_euler(order.upper(), angles_deg.reshape(-1, 3), degrees=True).as_matrix()
    return flat.reshape(*angles_deg.shape[:-1], 3, 3)


def axis_rotation(axis: str, degrees: float) -> np.ndarray:
    """(3, 3) rotation about a coordinate axis "x", "y" or "z"."""
    return Rotation.from_euler(axis.lower(), degrees, degrees=True).as_matrix()


def swing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3, 3) the smallest rotation taking direction ``a`` (3,) onto direction ``b`` (3,)."""
    a = np.asarray(a, dtype=np.float64) / np.linalg.norm(a)
    b = np.asarray(b, dtype=np.float64) / np.linalg.norm(b)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(np.dot(a, b))
    if s < 1e-9:
        if c > 0:
            return np.eye(3)
        # Opposite directions: any perpendicular axis gives a half turn.
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return rotvec_to_matrix(np.pi * perp / np.linalg.norm(perp))
    return rotvec_to_matrix(axis / s * np.arctan2(s, c))


def fraction(R: np.ndarray, t: float) -> np.ndarray:
    """(..., 3, 3) the rotation R^t: the same axis, ``t`` times the angle (slerp from I to R)."""
    return rotvec_to_matrix(matrix_to_rotvec(R) * t)


def slerp_rotvecs(r0: np.ndarray, r1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical interpolation between axis-angle rotations.

    Args:
        r0, r1: (N, ..., 3) axis-angle endpoints; t: (N,) weights in [0, 1].
    Returns:
        (N, ..., 3) axis-angle: exp(t * log(R1 R0^T)) R0 per item (the shorter arc).
    """
    R0, R1 = rotvec_to_matrix(r0), rotvec_to_matrix(r1)
    rel = matrix_to_rotvec(R1 @ np.swapaxes(R0, -1, -2))
    t = np.asarray(t, dtype=np.float64).reshape(-1, *([1] * (rel.ndim - 1)))
    return matrix_to_rotvec(rotvec_to_matrix(rel * t) @ R0)


def frame_from(x: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(3, 3) orthonormal frame whose columns are x, y = z cross x, z ~ up (Gram-Schmidt)."""
    x = np.asarray(x, dtype=np.float64) / np.linalg.norm(x)
    z = np.asarray(up, dtype=np.float64) - np.dot(up, x) * x
    z = z / np.linalg.norm(z)
    return np.stack([x, np.cross(z, x), z], axis=1)
