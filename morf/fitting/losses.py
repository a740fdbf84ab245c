"""Loss terms of the body fit (pure functions, batched over frames).

Per-frame terms take the frames' tensors and return (N,) losses; sequence terms return one loss
per neighbour pair (N-1,) or per shape. :mod:`morf.fitting.optimize` weights and sums them (its
``_data_terms`` for per-frame terms of the posed body, ``_sequence_terms`` for the rest): a new
term is a function here, a weight in ``FitConfig`` and one line there. The pelvis-shoulder twist
penalty lives with its measure in :mod:`morf.fitting.twist`.
"""

from __future__ import annotations

import torch


def geman_mcclure(sq_residual: torch.Tensor, sigma: float) -> torch.Tensor:
    """Robust Geman-McClure penalty of squared residuals: s^2 r^2 / (s^2 + r^2).

    Behaves like r^2 for small residuals and saturates at sigma^2 for outliers.
    """
    s2 = sigma * sigma
    return s2 * sq_residual / (s2 + sq_residual)


def keypoint_loss(projected: torch.Tensor, detected: torch.Tensor, scale: float, sigma: float,
                  weights: torch.Tensor | None = None) -> torch.Tensor:
    """Robust, confidence-weighted 2D keypoint reprojection loss per frame.

    Args:
        projected: (N, K, 2) model keypoints in pixels.
        detected: (N, K, 3) detections: x, y in pixels and confidence in [0, 1].
        scale: pixels per residual unit (e.g. 1% of the image height), so weights do not
            depend on the resolution.
        sigma: Geman-McClure scale in residual units.
        weights: optional (K,) per-keypoint weights.
    Returns:
        (N,) confidence-weighted sum of robust penalties.
    """
    r2 = ((projected - detected[..., :2]) / scale).pow(2).sum(-1)
    w = detected[..., 2]
    if weights is not None:
        w = w * weights
    return (w * geman_mcclure(r2, sigma)).sum(-1)


def keypoint_residual_px(projected: torch.Tensor, detected: torch.Tensor, min_confidence: float = 0.0) -> torch.Tensor:
    """(N,) confidence-weighted mean pixel distance over keypoints above ``min_confidence``."""
    d = (projected - detected[..., :2]).norm(dim=-1)
    w = detected[..., 2] * (detected[..., 2] > min_confidence)
    return (w * d).sum(-1) / w.sum(-1).clamp_min(1e-6)


def worst_keypoint_residual_px(projected: torch.Tensor, detected: torch.Tensor, k: int = 3,
                               min_confidence: float = 0.3) -> torch.Tensor:
    """(N,) mean of the ``k`` largest pixel distances among confident keypoints (0 if none).

    A wrong limb moves two to four keypoints; averaging all 23 would dilute it, the worst few
    do not.
    """
    d = (projected - detected[..., :2]).norm(dim=-1)
    d = torch.where(detected[..., 2] > min_confidence, d, torch.zeros_like(d))
    k = min(k, d.shape[-1])
    return d.topk(k, dim=-1).values.mean(-1)


def dice_loss_per_frame(pred: torch.Tensor, target: torch.Tensor, eps: float = 1.0) -> torch.Tensor:
    """(N,) Dice loss 1 - 2|P.T| / (|P| + |T|) of soft masks (N, H, W) in [0, 1].

    0 for identical masks, 1 for disjoint ones (``eps`` smooths empty masks: both empty -> 0).
    """
    inter = (pred * target).sum((-2, -1))
    total = pred.sum((-2, -1)) + target.sum((-2, -1))
    return 1.0 - (2.0 * inter + eps) / (total + eps)


def temporal_loss(x: torch.Tensor, pair_weights: torch.Tensor | None = None) -> torch.Tensor:
    """(N-1,) squared L2 between adjacent frames of (N, ...) parameters, times ``pair_weights``
    (N-1,) when given (how close each pair of neighbours is: ``FrameSpacing.temporal_weights``)."""
    if x.shape[0] < 2:
        return x.new_zeros(0)
    d = (x[1:] - x[:-1]).pow(2).reshape(x.shape[0] - 1, -1).sum(-1)
    return d if pair_weights is None else d * pair_weights


def rotation_temporal_loss(R: torch.Tensor, pair_weights: torch.Tensor | None = None) -> torch.Tensor:
    """(N-1,) squared Frobenius distance between adjacent rotations (N, 3, 3), times
    ``pair_weights`` (N-1,) when given; about angle^2 for small turns, and free of the axis-angle
    wrap at pi."""
    if R.shape[0] < 2:
        return R.new_zeros(0)
    d = 0.5 * (R[1:] - R[:-1]).pow(2).sum((-2, -1))
    return d if pair_weights is None else d * pair_weights


def rotation_acceleration_loss(R: torch.Tensor, pair_weights: torch.Tensor | None = None) -> torch.Tensor:
    """(N-2,) squared Frobenius norm of the second difference of rotations (N, 3, 3) over each
    triple of neighbours, times the product of its two ``pair_weights`` (1 / gap^2 each: a smooth
    motion's second difference grows with the gap squared).

    Why not the first difference: it penalises the speed of a turn, so a person turning briskly is
    held back, most at the ends of the turn where a frame has one neighbour to pull it (25 degrees
    at the start of a 225 deg/s spin). A turn at constant speed has (nearly) no second difference,
    while a frame's detection noise still has one."""
    if R.shape[0] < 3:
        return R.new_zeros(0)
    d = 0.5 * (R[2:] - 2 * R[1:-1] + R[:-2]).pow(2).sum((-2, -1))
    return d if pair_weights is None else d * pair_weights[1:] * pair_weights[:-1]


def shape_loss(shape: torch.Tensor, mean: torch.Tensor) -> torch.Tensor:
    """(S_batch,) squared distance of phenotypes (B, 6) from the prior mean (1, 6)."""
    return (shape - mean).pow(2).sum(-1)
