"""2D keypoints of synthetic frames: the same detector as real video when it is available,
otherwise the body model's own keypoints projected through the camera, with noise.
"""

from __future__ import annotations

import numpy as np
import torch

from morf.camera import PinholeCamera
from morf.errors import InputError


def make_detector(mode: str):
    """A MediaPipe person detector, or None for ground-truth keypoints.

    ``mode``: "none" never detects; "auto" uses MediaPipe when it can be loaded; "mediapipe"
    requires it and raises :class:`InputError` otherwise.
    """
    if mode == "none":
        return None
    try:
        from morf.capture.detect_mediapipe import MediaPipeDetector

        return MediaPipeDetector()
    except ImportError as e:
        if mode == "mediapipe":
            raise InputError(f"--detector mediapipe: MediaPipe is not available ({e})") from None
        return None
    except Exception as e:  # model files missing, runtime refuses to start, ...
        if mode == "mediapipe":
            raise InputError(f"--detector mediapipe: cannot start MediaPipe ({e})") from None
        return None


def close_detector(detector) -> None:
    close = getattr(detector, "close", None)
    if callable(close):
        close()


def project_keypoints(keypoints3d: np.ndarray, camera: PinholeCamera) -> np.ndarray:
    """(N, 23, 3) world keypoints -> (N, 23, 3) x, y in pixels and confidence.

    Confidence is 1 inside the image and 0 outside (a detector reports nothing there).
    """
    px = camera.project(torch.as_tensor(np.asarray(keypoints3d), dtype=torch.float64)).numpy()
    inside = (px[..., 0] >= 0) & (px[..., 0] < camera.width) & (px[..., 1] >= 0) & (px[..., 1] < camera.height)
    return np.concatenate([px, inside[..., None].astype(np.float64)], -1).astype(np.float32)


def noisy(points: np.ndarray, sigma_px: float, rng: np.random.Generator) -> np.ndarray:
    """Add Gaussian pixel noise of std ``sigma_px`` to x and y of (..., 23, 3) keypoints."""
    out = np.array(points, dtype=np.float32, copy=True)
    if sigma_px > 0:
        out[..., :2] += rng.normal(0.0, sigma_px, size=out[..., :2].shape).astype(np.float32)
    return out


def detect(detector, rgb: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Run the detector on one frame: ((23, 3) points, (H, W) float mask) or (None, None)."""
    d = detector.detect(rgb)
    if d is None or not getattr(d, "found", False):
        return None, None
    points = np.asarray(d.points, dtype=np.float32)
    if points.shape != (23, 3):
        return None, None
    mask = getattr(d, "mask", None)
    return points, None if mask is None else np.asarray(mask, dtype=np.float32)
