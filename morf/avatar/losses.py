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


def ssim_loss(pred: torch.Tensor, target: torch.Tensor, weight: torch.Tensor | None = None,
              window: int = 7) -> torch.Tensor:
    """1 - SSIM (Wang et al. 2004, K1 0.01, K2 0.03, peak 1) with a ``window`` x ``window`` box
    window, differentiable.

    Structure (edges, prints, the face) that an L1 loss averages away when the body is slightly
    misaligned from frame to frame; it needs no pretrained network. A box window (as in
    monodepth2's SSIM) made of cumulative sums instead of the metric's gaussian: on 2 CPU cores a
    depthwise gaussian convolution with its backward took 0.4 s a step, average pooling 0.2 s,
    cumulative sums about 3x less than pooling. Zero padding at the border. With
    ``weight`` (B, 1, H, W) the SSIM map is averaged over the weighted pixels, else everywhere.
    """
    r = window // 2

    def box(x, dim):  # sliding sum along ``dim`` by cumulative sums (zero padding)
        n = x.shape[dim]
        c = torch.cumsum(F.pad(x, [0, 0] * (x.dim() - 1 - dim) + [r + 1, r]), dim)
        return c.narrow(dim, 2 * r + 1, n) - c.narrow(dim, 0, n)

    def blur(x):
        return box(box(x, 3), 2) / window ** 2

    mu_x, mu_y = blur(pred), blur(target)
    sxx = blur(pred * pred) - mu_x ** 2
    syy = blur(target * target) - mu_y ** 2
    sxy = blur(pred * target) - mu_x * mu_y
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    smap = ((2 * mu_x * mu_y + c1) * (2 * sxy + c2)) / ((mu_x ** 2 + mu_y ** 2 + c1) * (sxx + syy + c2))
    if weight is None:
        return 1 - smap.mean()
    w = weight.expand_as(smap)
    return 1 - (smap * w).sum() / w.sum().clamp_min(1.0)


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
