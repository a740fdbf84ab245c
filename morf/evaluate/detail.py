"""Scores that see detail in a region of a render and a real frame, and do not reward blur.

PSNR and plain SSIM compare pixel with pixel. A render whose detail is right but sits two pixels
off (the fit's error, not the avatar's) loses twice on every edge, while a blurred render loses
little anywhere, so those scores prefer blur. The scores here fix that:

* ``ssim_shift``: SSIM (gaussian window, :func:`morf.avatar.metrics.ssim_map`) of the region at the
  best integer shift of the render within +-``max_shift`` pixels (4 at native size). A shift
  cannot make a blurred region sharp, so blur keeps its loss.
* ``gmsd``: gradient magnitude similarity deviation (Xue et al. 2014), the standard deviation over
  the region of ``(2 g_r g_d + c) / (g_r^2 + g_d^2 + c)`` with ``g`` the Prewitt gradient magnitude of
  the luminance, at the shift ``ssim_shift`` chose. Lower is better; blur flattens gradients
  unevenly and so scores badly. No learned weights.
* ``hf_ratio``: the high-frequency energy of the render in the region over the real frame's
  (luminance minus its gaussian blur, sigma 1 px, squared and summed). Under 1: the render is
  blurrier than the real frame; over 1: noisier. It says nothing about where the detail is, so it
  is read beside the two scores above.
* ``hf_ratio_inside``: the same ratio counted only where both images show the person's inside,
  at least ``HF_INSET`` pixels from the edge of the real mask and of the render's (its alpha over
  0.5, at the chosen shift; :func:`inside_mask`). The real frames are composited over the backdrop
  with a binary mask, a hard step a render's alpha does not have; on a small head that step holds
  most of the box's real high-frequency energy, so the box's ratio measures the matte's edge, not
  the face. Without the render's own edge left out, an outline a few pixels off would count as
  detail inside.
* ``psnr``: plain PSNR of the region (no shift), to show what the others correct.

Images are (3, H, W) float tensors or arrays in [0, 1]; a region is a box (y0, x0, y1, x1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GMSD_C = 170 / 255 ** 2  # Xue et al.'s constant for 8-bit images, on a [0, 1] scale
HF_SIGMA = 1.0  # pixels; the blur whose residual counts as high frequency
HF_INSET = 3  # pixels from the real mask's edge before ``hf_ratio_inside`` counts a pixel (3 sigma)
SSIM_RADIUS = 5  # the 11-tap SSIM window's half width
NATIVE_SHIFT = 4  # pixels of tolerated misalignment at native size


@dataclass(frozen=True)
class RegionScores:
    """One region of one frame. Fields: psnr (dB, unshifted); ssim_shift; gmsd (lower is better);
    hf_render, hf_real: high-frequency energy (sum over the region); shift: (dy, dx) the render was
    moved by; pixels: the region's pixel count; hf_render_inside, hf_real_inside: the energies inside
    the real person (:func:`inside_mask`; the whole region when no mask was given)."""

    psnr: float
    ssim_shift: float
    gmsd: float
    hf_render: float
    hf_real: float
    shift: tuple[int, int]
    pixels: int
    hf_render_inside: float = float("nan")
    hf_real_inside: float = float("nan")

    @property
    def hf_ratio(self) -> float:
        return self.hf_render / self.hf_real if self.hf_real > 0 else float("nan")

    @property
    def hf_ratio_inside(self) -> float:
        return self.hf_render_inside / self.hf_real_inside if self.hf_real_inside > 0 else float("nan")


def max_shift_for(side: int, native_side: int) -> int:
    """The tolerated shift at ``side`` px for a crop of ``native_side`` capture pixels (4 at native)."""
    return max(1, int(round(NATIVE_SHIFT * side / max(1, native_side))))


def _np(img) -> np.ndarray:
    a = img.detach().cpu().numpy() if hasattr(img, "detach") else np.asarray(img)
    return a.astype(np.float64)


def luminance(img: np.ndarray) -> np.ndarray:
    """(3, H, W) -> (H, W) Rec. 601 luma."""
    return 0.299 * img[0] + 0.587 * img[1] + 0.114 * img[2]


def gradient_magnitude(lum: np.ndarray) -> np.ndarray:
    """Prewitt gradient magnitude of (..., H, W) luminance (same size, edges replicated)."""
    from scipy.ndimage import correlate1d

    d = correlate1d(lum, np.array([1.0, 0.0, -1.0]) / 3, axis=-1, mode="nearest")
    gx = correlate1d(d, np.ones(3), axis=-2, mode="nearest")
    d = correlate1d(lum, np.array([1.0, 0.0, -1.0]) / 3, axis=-2, mode="nearest")
    gy = correlate1d(d, np.ones(3), axis=-1, mode="nearest")
    return np.sqrt(gx * gx + gy * gy)


def gmsd(pred: np.ndarray, gt: np.ndarray) -> float:
    """GMSD of two (3, h, w) images over their whole extent (lower is better, 0 = same gradients)."""
    gp, gg = gradient_magnitude(luminance(pred)), gradient_magnitude(luminance(gt))
    gms = (2 * gp * gg + GMSD_C) / (gp * gp + gg * gg + GMSD_C)
    return float(gms.std())


def hf_energy(img: np.ndarray, pad: int = 0, where: np.ndarray | None = None) -> float:
    """Energy of luminance minus its gaussian blur (sigma ``HF_SIGMA``), summed inside a (3, h, w)
    image less ``pad`` pixels of border (the border gives the blur its context); with ``where``, a
    bool (h - 2 pad, w - 2 pad) array, only over its pixels."""
    from scipy.ndimage import gaussian_filter

    lum = luminance(img)
    res = lum - gaussian_filter(lum, HF_SIGMA, mode="nearest")
    h, w = res.shape
    e = res[pad:h - pad, pad:w - pad] ** 2
    return float(e.sum() if where is None else e[where].sum())


def inside_mask(mask: np.ndarray, inset: int = HF_INSET) -> np.ndarray:
    """(H, W) bool: the pixels of the (H, W) person ``mask`` at least ``inset`` pixels from its edge
    (the border of the image does not count as an edge)."""
    from scipy.ndimage import distance_transform_edt

    m = np.asarray(mask, bool)
    return distance_transform_edt(np.pad(m, 1, mode="edge"))[1:-1, 1:-1] >= inset


def _blur(x: np.ndarray) -> np.ndarray:
    """The SSIM window's gaussian over the last two axes, edges replicated."""
    from scipy.ndimage import correlate1d

    from morf.avatar.metrics import _gaussian_1d

    g = _gaussian_1d().numpy().astype(x.dtype)
    return correlate1d(correlate1d(x, g, axis=-1, mode="nearest"), g, axis=-2, mode="nearest")


def _shift_ssims(lp: np.ndarray, lg: np.ndarray, h: int, w: int, m: int, shifts) -> np.ndarray:
    """Luminance SSIM of the (h, w) box at offset (m, m) of ``lg`` against ``lp``'s box moved by
    each (dy, dx) of ``shifts`` (|dy|, |dx| <= m - SSIM_RADIUS).

    The gaussian moments of each image are shift-equivariant: they are blurred once and sliced;
    only the cross moment is blurred again per shift, and only over the box grown by the window.
    """
    r = SSIM_RADIUS
    mu_p, mu_g = _blur(lp), _blur(lg)
    var_p, var_g = _blur(lp * lp) - mu_p ** 2, _blur(lg * lg) - mu_g ** 2
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    box = (slice(m, m + h), slice(m, m + w))
    mg, vg = mu_g[box], var_g[box]
    g_grown = lg[m - r:m + h + r, m - r:m + w + r]
    out = []
    for dy, dx in shifts:
        moved = (slice(m + dy, m + dy + h), slice(m + dx, m + dx + w))
        mp, vp = mu_p[moved], var_p[moved]
        prod = lp[m - r + dy:m + h + r + dy, m - r + dx:m + w + r + dx] * g_grown
        cov = _blur(prod)[r:r + h, r:r + w] - mp * mg
        out.append(((2 * mp * mg + c1) * (2 * cov + c2) / ((mp ** 2 + mg ** 2 + c1) * (vp + vg + c2))).mean())
    return np.asarray(out)


COARSE_PIXELS = 128 * 128  # larger regions search their shift coarse to fine


def _luma_crop(img: np.ndarray, box, m: int) -> np.ndarray:
    """Float32 luminance of ``box`` grown by ``m`` pixels (edges replicated past the image)."""
    y0, x0, y1, x1 = box
    return np.pad(luminance(img), m, mode="edge")[y0:y1 + 2 * m, x0:x1 + 2 * m].astype(np.float32)


def _by_size(shifts):
    return sorted(shifts, key=lambda s: (abs(s[0]) + abs(s[1]), s))


def best_shift(pred: np.ndarray, gt: np.ndarray, box, max_shift: int) -> tuple[int, int]:
    """The (dy, dx) within +-``max_shift`` that maximises the luminance SSIM of the render's
    shifted box against the real box (ties: the smallest shift).

    A region over ``COARSE_PIXELS`` is searched at half resolution first, then within +-1 pixel
    of the coarse answer at full resolution: about a fifth of the work of the full search, which
    matters for the whole person at native size.
    """
    y0, x0, y1, x1 = box
    h, w = y1 - y0, x1 - x0
    m = max_shift + SSIM_RADIUS
    lp, lg = _luma_crop(pred, box, m), _luma_crop(gt, box, m)
    full = [(dy, dx) for dy in range(-max_shift, max_shift + 1) for dx in range(-max_shift, max_shift + 1)]
    if h * w > COARSE_PIXELS and max_shift >= 2:
        half = (max_shift + 1) // 2
        mh = half + SSIM_RADIUS
        cb = (y0 // 2, x0 // 2, y0 // 2 + h // 2, x0 // 2 + w // 2)
        cp, cg = (_luma_crop(_half(img), cb, mh) for img in (pred, gt))
        coarse = _by_size((dy, dx) for dy in range(-half, half + 1) for dx in range(-half, half + 1))
        cy, cx = coarse[int(np.argmax(_shift_ssims(cp, cg, h // 2, w // 2, mh, coarse)))]
        full = [(dy, dx) for dy, dx in full if abs(dy - 2 * cy) <= 1 and abs(dx - 2 * cx) <= 1]
    shifts = _by_size(full)
    return shifts[int(np.argmax(_shift_ssims(lp, lg, h, w, m, shifts)))]  # argmax: first best = smallest shift


def _half(img: np.ndarray) -> np.ndarray:
    """(3, H, W) -> (3, H // 2, W // 2) by 2 x 2 averages."""
    c, H, W = img.shape
    return img[:, :H // 2 * 2, :W // 2 * 2].reshape(c, H // 2, 2, W // 2, 2).mean((2, 4))


def _inside_box(inside, inside_pred, box, shift, m: int):
    """The (h, w) bool of ``box`` inside both masks, the render's moved by ``shift`` (None: neither)."""
    y0, x0, y1, x1 = box
    where = None if inside is None else np.asarray(inside, bool)[y0:y1, x0:x1]
    if inside_pred is not None:
        dy, dx = shift
        moved = np.pad(np.asarray(inside_pred, bool), m)[y0 + dy + m:y1 + dy + m, x0 + dx + m:x1 + dx + m]
        where = moved if where is None else where & moved
    return where


def region_scores(pred, gt, box, max_shift: int = NATIVE_SHIFT, inside: np.ndarray | None = None,
                  inside_pred: np.ndarray | None = None) -> RegionScores:
    """All scores of the render ``pred`` against the real ``gt`` (both (3, H, W), composited over
    the same backdrop) in ``box`` = (y0, x0, y1, x1), end exclusive. The shift is chosen on
    luminance; ``ssim_shift`` is then the colour SSIM (mean over channels) at that shift.
    ``inside``, ``inside_pred``: the (H, W) :func:`inside_mask` of the real frame and of the render
    (moved with it), for the energies inside; either may be left out."""
    import torch

    from morf.avatar.metrics import ssim_map

    pred, gt = _np(pred), _np(gt)
    y0, x0, y1, x1 = box
    r = SSIM_RADIUS
    dy, dx = best_shift(pred, gt, box, max_shift)
    m = max_shift + r
    pp = np.pad(pred, ((0, 0), (m, m), (m, m)), mode="edge")
    gp = np.pad(gt, ((0, 0), (m, m), (m, m)), mode="edge")
    p = pp[:, y0 + max_shift + dy:y1 + m + r + dy, x0 + max_shift + dx:x1 + m + r + dx]  # box grown by r
    g = gp[:, y0 + max_shift:y1 + m + r, x0 + max_shift:x1 + m + r]
    ssim = float(ssim_map(torch.from_numpy(p), torch.from_numpy(g)).mean())  # valid part = the box
    mse = float(((pred[:, y0:y1, x0:x1] - gt[:, y0:y1, x0:x1]) ** 2).mean())
    psnr = float("inf") if mse == 0 else -10 * math.log10(mse)
    where = _inside_box(inside, inside_pred, box, (dy, dx), m)
    return RegionScores(psnr, ssim, gmsd(p[:, r:-r, r:-r], g[:, r:-r, r:-r]), hf_energy(p, r), hf_energy(g, r),
                        (dy, dx), int((y1 - y0) * (x1 - x0)), hf_energy(p, r, where), hf_energy(g, r, where))
