"""Image quality metrics: PSNR, SSIM (own implementation), their masked variants, and a
weight-free temporal stability metric.

Images are (B, 3, H, W) or (3, H, W) float in [0, 1]; masks (B, 1, H, W) / (B, H, W) bool or float.

Temporal flicker (lower is better): over consecutive frames of a sequence,
``mean_t  sum_p m_p |(pred_t - pred_{t-1}) - (gt_t - gt_{t-1})|_p / sum_p m_p`` with ``m`` the
union of the two frames' person masks. It is zero when the prediction changes exactly as the
ground truth does, whatever its per-frame error, so it isolates flicker and popping from static
appearance errors (a weight-free stand-in for tLPIPS).

Evaluation composites both the render and the frame over the same flat background colour
(:func:`composite_over`, :func:`background_colour`), exactly as the player composites
(``rgb + (1 - mask) * background``). Comparing on black instead exaggerates SSIM errors: SSIM's
luminance term on a black region is ``C1 / (mu_x^2 + C1)`` with ``C1 = 1e-4``, so a render that
leaks 0.01 into the background halves SSIM there, while the same leak over a mid-grey background
costs almost nothing. SSIM itself matches scikit-image's ``structural_similarity(gaussian_weights=True,
sigma=1.5, use_sample_covariance=False, data_range=1)`` to 5 digits (checked on real photos).
"""

from __future__ import annotations

import math

import torch


def _batch(x: torch.Tensor) -> torch.Tensor:
    return x.unsqueeze(0) if x.dim() == 3 else x


def _mask(m: torch.Tensor | None, ref: torch.Tensor) -> torch.Tensor | None:
    if m is None:
        return None
    m = m.to(ref.dtype)
    if m.dim() == 2:
        m = m[None, None]
    elif m.dim() == 3:
        m = m.unsqueeze(1)
    return m


def psnr(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor | None = None) -> float:
    """Peak signal-to-noise ratio in dB (peak 1); with a mask, the MSE over masked pixels only."""
    pred, target = _batch(pred).float(), _batch(target).float()
    se = (pred - target) ** 2
    m = _mask(mask, se)
    mse = se.mean() if m is None else (se * m).sum() / (m.expand_as(se).sum().clamp_min(1.0))
    return float("inf") if float(mse) == 0 else float(-10 * torch.log10(mse))


def _gaussian_1d(size: int = 11, sigma: float = 1.5) -> torch.Tensor:
    x = torch.arange(size, dtype=torch.float64) - (size - 1) / 2
    g = torch.exp(-(x ** 2) / (2 * sigma ** 2))
    return g / g.sum()


def ssim_map(pred: torch.Tensor, target: torch.Tensor, window: int = 11, sigma: float = 1.5,
             k1: float = 0.01, k2: float = 0.03) -> torch.Tensor:
    """(B, C, H-10, W-10) SSIM map (Wang et al. 2004), gaussian window, valid convolution, peak 1.

    Float64 on the CPU: the separable gaussian runs as two 1-D scipy correlations (about 10x
    faster here than torch's single-channel convolutions); the border is cropped to the valid part.
    """
    from scipy.ndimage import correlate1d

    pred = _batch(pred).detach().double().cpu().numpy()
    target = _batch(target).detach().double().cpu().numpy()
    g = _gaussian_1d(window, sigma).numpy()
    c1, c2 = (k1 ** 2), (k2 ** 2)
    r = window // 2

    def blur(x):
        y = correlate1d(correlate1d(x, g, axis=-1, mode="constant"), g, axis=-2, mode="constant")
        return y[..., r:y.shape[-2] - r, r:y.shape[-1] - r]

    mu_x, mu_y = blur(pred), blur(target)
    sxx = blur(pred * pred) - mu_x ** 2
    syy = blur(target * target) - mu_y ** 2
    sxy = blur(pred * target) - mu_x * mu_y
    smap = ((2 * mu_x * mu_y + c1) * (2 * sxy + c2)) / ((mu_x ** 2 + mu_y ** 2 + c1) * (sxx + syy + c2))
    return torch.from_numpy(smap)


def ssim(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor | None = None) -> float:
    """Mean SSIM; with a mask, averaged over window centres inside the mask."""
    smap = ssim_map(pred, target)
    m = _mask(mask.detach().cpu() if mask is not None else None, smap)
    if m is None:
        return float(smap.mean())
    r = (m.shape[-1] - smap.shape[-1]) // 2
    m = m[..., r:m.shape[-2] - r, r:m.shape[-1] - r].expand_as(smap)
    return float((smap * m).sum() / m.sum().clamp_min(1.0))


def background_colour(images: torch.Tensor, masks: torch.Tensor) -> torch.Tensor:
    """(3,) median colour of the pixels outside the person masks. images (B, 3, H, W), masks (B, 1, H, W)."""
    images = _batch(images)
    outside = (_mask(masks, images) < 0.5)[:, 0]
    px = images.permute(0, 2, 3, 1)[outside]  # (P, 3)
    if px.shape[0] == 0:
        return torch.zeros(3, dtype=images.dtype, device=images.device)
    return px.median(dim=0).values


def composite_over(rgb: torch.Tensor, alpha: torch.Tensor, colour: torch.Tensor) -> torch.Tensor:
    """``clamp(rgb + (1 - alpha) * colour, 0, 1)``: premultiplied RGB (B, 3, H, W) with alpha
    (B, 1, H, W) over a flat (3,) colour, as the player composites."""
    return (rgb + (1 - _mask(alpha, rgb)) * colour.to(rgb).view(1, 3, 1, 1)).clamp(0, 1)


def temporal_flicker(preds: torch.Tensor, targets: torch.Tensor, masks: torch.Tensor | None = None) -> float:
    """Temporal flicker of a sequence (see module docstring). preds, targets: (T, 3, H, W)."""
    if preds.shape[0] < 2:
        return float("nan")
    dp = preds[1:].float() - preds[:-1].float()
    dg = targets[1:].float() - targets[:-1].float()
    err = (dp - dg).abs().mean(1, keepdim=True)
    if masks is None:
        return float(err.mean())
    m = _mask(masks, err)
    m = torch.maximum(m[1:], m[:-1])
    per = (err * m).flatten(1).sum(1) / m.flatten(1).sum(1).clamp_min(1.0)
    return float(per.mean())


def summarize(values: list[float]) -> float | None:
    """Mean of finite values, None if there are none."""
    v = [x for x in values if x is not None and math.isfinite(x)]
    return sum(v) / len(v) if v else None
