"""Foot contact for retargeted clips: feet on the floor, less foot sliding.

Both work on the posed body: the clip is evaluated with the body model (batches of frames), and
only the root translation changes, so the joint rotations stay exactly as retargeted.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d

from morf.motion.anny_rest import FOOT_KEYPOINTS, FootPointEvaluator, target_rest
from morf.motion.clip import MotionClip


@dataclass(frozen=True)
class GroundConfig:
    """How feet meet the floor."""

    ground: float = 0.0  # floor height (z) in Anny's world, metres
    smoothing_s: float = 0.08  # Gaussian sigma of the vertical correction, seconds
    tolerance: float = 0.005  # how far the smoothed correction may leave the lowest foot above its target, metres
    reduce_sliding: bool = True  # shift the root horizontally so planted feet stay put
    contact_height: float = 0.03  # a foot whose lowest point is this close to the floor may be planted, metres
    contact_speed: float = 0.4  # ... and moving slower than this, m/s
    batch_size: int = 64  # frames per body model evaluation


@torch.no_grad()
def foot_points(clip: MotionClip, model, shape: torch.Tensor | None = None, batch_size: int = 64,
                control=None) -> np.ndarray:
    """(T, 6, 3) the six foot keypoints (toes, heels) of every frame of ``clip``, metres."""
    evaluate = FootPointEvaluator(model, shape)
    out = np.empty((clip.num_frames, len(FOOT_KEYPOINTS), 3))
    for s in range(0, clip.num_frames, batch_size):
        if control is not None:
            control.check()
        frames = np.arange(s, min(s + batch_size, clip.num_frames))
        out[frames] = evaluate(clip.poses(frames, device=evaluate.shape.device)).double().cpu().numpy()
    return out


def place_on_ground(clip: MotionClip, model, shape: torch.Tensor | None = None, clearance: np.ndarray | None = None,
                    config: GroundConfig = GroundConfig(), control=None) -> MotionClip:
    """Shift each frame vertically so the lowest foot point sits ``clearance`` (T,) above the floor
    (default 0: always touching); then, if asked, reduce foot sliding. Returns a new clip.

    The vertical correction is smoothed over time (mocap jitter) but kept within
    [exact, exact + ``tolerance``] of the exact per-frame one: no foot goes below its target and
    none floats more than the tolerance above it."""
    pts = foot_points(clip, model, shape, config.batch_size, control)
    T = clip.num_frames
    clearance = np.zeros(T) if clearance is None else np.asarray(clearance, dtype=np.float64)
    lowest = pts[..., 2].min(axis=1)
    exact = config.ground + clearance - lowest
    corr = exact
    if T > 1 and config.smoothing_s > 0:
        corr = gaussian_filter1d(exact, sigma=config.smoothing_s * clip.fps, mode="nearest")
    corr = np.clip(corr, exact, exact + config.tolerance)
    transl = clip.transl.astype(np.float64).copy()
    transl[:, 2] += corr
    pts[..., 2] += corr[:, None]
    if config.reduce_sliding and T > 2:
        transl[:, :2] += sliding_correction(pts, foot_sides(model, shape), clip.fps, config)
    return replace(clip, transl=transl.astype(np.float32))


def foot_sides(model, shape) -> tuple[list[int], list[int]]:
    """Positions (within FOOT_KEYPOINTS) of the left and right foot points."""
    rest = target_rest(model, shape)
    pos = {k: i for i, k in enumerate(FOOT_KEYPOINTS)}
    return [pos[k] for k in rest.foot_points[0]], [pos[k] for k in rest.foot_points[1]]


def contact_weights(pts: np.ndarray, sides, fps: float, config: GroundConfig) -> np.ndarray:
    """(T, 2) how planted each foot is (0..1): low and slow, softly thresholded."""
    w = np.zeros((pts.shape[0], 2))
    for f, idx in enumerate(sides):
        foot = pts[:, idx]
        height = foot[..., 2].min(axis=1) - config.ground
        centre = foot[..., :2].mean(axis=1)
        speed = np.linalg.norm(np.gradient(centre, axis=0), axis=1) * fps
        low = np.clip(2.0 - height / config.contact_height, 0.0, 1.0)
        slow = np.clip(2.0 - speed / config.contact_speed, 0.0, 1.0)
        w[:, f] = low * slow
    return w


def sliding_correction(pts: np.ndarray, sides, fps: float, config: GroundConfig) -> np.ndarray:
    """(T, 2) horizontal root offsets that cancel the motion of planted feet.

    Frame to frame, the root moves against the weighted mean step of the planted feet, so a
    fully planted foot stays where it landed; swing phases keep the source's own motion.
    """
    w = contact_weights(pts, sides, fps, config)
    steps = np.zeros((pts.shape[0], 2, 2))
    for f, idx in enumerate(sides):
        centre = pts[:, idx, :2].mean(axis=1)
        steps[1:, f] = np.diff(centre, axis=0)
    wsum = w.sum(axis=1, keepdims=True)
    delta = -(w[:, :, None] * steps).sum(axis=1) / np.maximum(wsum, 1.0)
    return np.cumsum(delta, axis=0)


def foot_skate(clip: MotionClip, model, shape: torch.Tensor | None = None,
               config: GroundConfig = GroundConfig()) -> float:
    """Mean horizontal speed (m/s) of planted feet, weighted by how planted they are: 0 is no sliding."""
    pts = foot_points(clip, model, shape, config.batch_size)
    sides = foot_sides(model, shape)
    w = contact_weights(pts, sides, clip.fps, config)
    total, weight = 0.0, 0.0
    for f, idx in enumerate(sides):
        centre = pts[:, idx, :2].mean(axis=1)
        speed = np.linalg.norm(np.gradient(centre, axis=0), axis=1) * clip.fps
        total += float((w[:, f] * speed).sum())
        weight += float(w[:, f].sum())
    return total / max(weight, 1e-9)
