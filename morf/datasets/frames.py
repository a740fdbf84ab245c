"""What a dataset adapter hands the project writer: undistorted frames with their masks.

Both datasets ship lens distortion coefficients while our :class:`~morf.camera.PinholeCamera`
has none, so frames and masks are undistorted once at import (as InstantAvatar and Neural
Body do before training) and the project stores the distortion-free camera.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from morf.camera import PinholeCamera
from morf.errors import InputError


@dataclass(frozen=True)
class DatasetFrame:
    """One frame of a dataset sequence, ready for a capture project.

    Fields:
        rgb: (H, W, 3) uint8 RGB, undistorted.
        mask: (H, W) bool person mask, undistorted, aligned with ``rgb``.
        source_index: the frame's index in the dataset sequence.
        split: "train" | "test" | "" (outside both) under the dataset's published split.
    """

    rgb: np.ndarray
    mask: np.ndarray
    source_index: int
    split: str


def camera_from_opencv(K, R, t, width: int, height: int, what: str) -> PinholeCamera:
    """A PinholeCamera from OpenCV K (3, 3), world-to-camera R (3, 3) and t (3,) in metres."""
    K, R, t = (np.asarray(a, np.float64) for a in (K, R, t))
    if K.shape != (3, 3) or R.shape != (3, 3) or t.size != 3:
        raise InputError(f"{what}: camera must have K (3, 3), R (3, 3), T (3,), got {K.shape}, {R.shape}, {t.shape}")
    if not (np.isfinite(K).all() and np.isfinite(R).all() and np.isfinite(t).all()):
        raise InputError(f"{what}: camera has non-finite values")
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        raise InputError(f"{what}: focal lengths must be positive, got {K[0, 0]}, {K[1, 1]}")
    if abs(np.linalg.det(R) - 1) > 1e-3 or np.abs(R @ R.T - np.eye(3)).max() > 1e-3:
        raise InputError(f"{what}: R is not a rotation matrix")
    return PinholeCamera(float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2]), int(width), int(height),
                         R, t.reshape(3))


def distortion(coeffs) -> np.ndarray | None:
    """OpenCV distortion coefficients (k1, k2, p1, p2[, k3]) as a flat array; None when all zero."""
    d = np.asarray(coeffs if coeffs is not None else [], np.float64).reshape(-1)
    if d.size == 0 or not np.any(d):
        return None
    if not np.isfinite(d).all():
        raise InputError(f"distortion coefficients are not finite: {d}")
    return d


def undistort(rgb: np.ndarray, mask: np.ndarray, camera: PinholeCamera, dist: np.ndarray | None):
    """(H, W, 3) uint8 and (H, W) bool -> both undistorted with ``dist`` (same K in and out)."""
    if dist is None:
        return rgb, mask
    K = camera.K
    rgb = cv2.undistort(rgb, K, dist)
    m = cv2.undistort(mask.astype(np.uint8) * 255, K, dist)
    return rgb, m > 127
