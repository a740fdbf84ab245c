"""Training losses (MoRF Sec. 4.3) as pure functions on tensors.

Images are (B, 3, H, W) in [0, 1]; masks (B, 1, H, W) in [0, 1]; offsets (B, 2, H, W).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F


def l1_loss(pred: torch.Tensor, target: torch.Tensor, weight: torch.Tensor | None = None) -> torch.Tensor:
    """Mean absolute error; with ``weight`` (B, 1, H, W) the weighted mean over weighted pixels."""
    diff = (pred - target).abs()
    if weight is None:
        return diff.mean()
    w = weight.expand_as(diff)
    return (diff * w).sum() / w.sum().clamp_min(1.0)


def dice_loss(prob: torch.Tensor, target: torch.Tensor, eps: float = 1.0) -> torch.Tensor:
    """1 - Dice coefficient per image, averaged: ``1 - (2|P.T| + eps) / (|P| + |T| + eps)``."""
    p = prob.flatten(1)
    t = target.flatten(1)
    num = 2 * (p * t).sum(1) + eps
    den = p.sum(1) + t.sum(1) + eps
    return (1 - num / den).mean()


def tv_loss(x: torch.Tensor) -> torch.Tensor:
    """Anisotropic total variation: mean |x[i+1] - x[i]| over both spatial axes (L1)."""
    dy = (x[..., 1:, :] - x[..., :-1, :]).abs().mean()
    dx = (x[..., :, 1:] - x[..., :, :-1]).abs().mean()
    return dx + dy


def offset_l2(offsets: torch.Tensor) -> torch.Tensor:
    """Mean squared offset magnitude (the Delta -> 0 term)."""
    return (offsets ** 2).sum(1).mean()


def gan_generator_loss(fake_logits: list[torch.Tensor]) -> torch.Tensor:
    """Non-saturating generator loss ``softplus(-D(fake))`` averaged over scales."""
    return sum(F.softplus(-f).mean() for f in fake_logits) / len(fake_logits)


def gan_discriminator_loss(real_logits: list[torch.Tensor], fake_logits: list[torch.Tensor]) -> torch.Tensor:
    """``softplus(-D(real)) + softplus(D(fake))`` averaged over scales."""
    return sum(F.softplus(-r).mean() + F.softplus(f).mean() for r, f in zip(real_logits, fake_logits)) / len(real_logits)


def feature_matching_loss(real_feats: list[list[torch.Tensor]], fake_feats: list[list[torch.Tensor]]) -> torch.Tensor:
    """L1 between discriminator features of real and fake images (all layers but the logits)."""
    total, n = 0.0, 0
    for rs, fs in zip(real_feats, fake_feats):
        for r, f in zip(rs[:-1], fs[:-1]):
            total = total + F.l1_loss(f, r.detach())
            n += 1
    return total / max(n, 1)
