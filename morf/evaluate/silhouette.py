"""The silhouette score of ``morf eval``: how well the rendered mask covers the real person.

Colour scores barely move when a loose hem or a hood is cut away (those pixels are a small share
of the person), but the mask's IoU does: it is the score that says whether the avatar's outline
holds the clothes the body model lacks (the fit's clothing offsets, :mod:`morf.fitting.offsets`).
"""

from __future__ import annotations

import numpy as np
import torch
from morf.train.trained_avatar import render_batch


def mask_iou_of(pred: np.ndarray, real: np.ndarray) -> float:
    """IoU of two (H, W) bool masks; NaN when both are empty."""
    union = np.logical_or(pred, real).sum()
    return float(np.logical_and(pred, real).sum() / union) if union else float("nan")


@torch.no_grad()
def mask_iou(avatar, frames, threshold: float = 0.5) -> float | None:
    """Mean over the frames of a FrameSet of the IoU between ``avatar``'s rendered mask
    (probability > ``threshold``) and the real person mask; None when no frame has a person."""
    vals = []
    for i in range(frames.num_frames):
        b = frames.batch([i])
        _, alpha = render_batch(avatar, b)
        v = mask_iou_of(alpha[0, 0].numpy() > threshold, frames.masks[i])
        if np.isfinite(v):
            vals.append(v)
    return round(float(np.mean(vals)), 5) if vals else None
