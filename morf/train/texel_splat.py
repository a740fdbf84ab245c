"""Where a frame's pixels land in the texture, and how a texel seen by few pixels is kept from
taking one pixel's noise.

The plain projection (:func:`morf.train.inpaint.projected_texels`) gives each pixel to the one
texel its UV falls in. Where the atlas is denser than the frames (the head's texels are about
twice as dense as the training frames' pixels at 256 px, docs/avatar.md), a frame hits one texel
in four and leaves pinholes between them; a texel hit by one or two pixels of the whole capture
holds their colour, noise and a misplaced edge pixel included. On a real capture at 256 px a
quarter of the seen texels had fewer than four pixels, and 38 % of those with one pixel stood
more than 30 levels off the median of their 3 x 3 neighbours: the speckle in the hair and on the
face that the renderer then draws at the player's size.

Two remedies, each optional:

* ``bilinear`` splatting: every pixel is shared among the four texels around its UV with the
  bilinear weights, the adjoint of the bilinear lookup the renderer does; neighbouring texels
  are hit by the same pixels, so the pinholes close and the counts even out.
* a neighbourhood prior (``prior_count`` k > 0): each texel's mean is drawn towards the mean of
  its surroundings as if k pixels of that colour had been added,
  ``(sum + k * prior) / (count + k)``; the prior is itself the normalised-convolution mean at
  1 texel, drawn the same way towards the one at 3 texels. A texel seen by many pixels keeps its
  own colour; one seen by a single pixel takes mostly its neighbourhood's.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from morf.train.frames import UV_SCALE

PRIOR_SIGMAS = (3.0, 1.0)  # texels: the prior's scales, coarse to fine


@dataclass(frozen=True)
class Projection:
    """How the frames' pixels are averaged into texels (:func:`morf.train.inpaint.project_rgb_texture`).

    Fields: facing_power p > 0 weights each pixel by its facing |cos| ** p (0: equally);
    bilinear shares each pixel among the four texels around its UV (False: the one it falls in);
    prior_count k > 0 draws each texel towards its neighbourhood by k pseudo-pixels (0: none);
    edge_inset n > 0 leaves out the pixels within n pixels of the person mask's outline (0: none):
    they mix the person with the backdrop, and a surface seen near the outline (an eye in a
    profile) would take the backdrop's colour from them.
    back_projections n > 0 refines the projected colours by n passes of back-projection
    (:mod:`morf.train.back_project`).
    The defaults are the plain nearest-texel mean, the RGB floor's.
    """

    facing_power: float = 0.0
    bilinear: bool = False
    prior_count: float = 0.0
    edge_inset: int = 0
    back_projections: int = 0


def texel_weights(uv: np.ndarray, size: int, bilinear: bool) -> list[tuple[np.ndarray, np.ndarray | None]]:
    """(P, 2) packed UVs (``FrameSet.uv`` values) -> [(texel index (P,), weight (P,) or None)]:
    one entry (the texel the UV falls in, weight 1) for the plain projection, four with the
    bilinear weights for ``bilinear``. Texel (row, col) has index row * size + col, row 0 at v = 1."""
    u = uv[:, 0].astype(np.float64) / UV_SCALE * size
    v = (1 - uv[:, 1].astype(np.float64) / UV_SCALE) * size
    if not bilinear:
        col = np.clip(u.astype(np.int64), 0, size - 1)
        row = np.clip(v.astype(np.int64), 0, size - 1)
        return [(row * size + col, None)]
    x, y = u - 0.5, v - 0.5  # texel centres on integers
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    out = []
    for dx, dy, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        col = np.clip(x0 + dx, 0, size - 1).astype(np.int64)
        row = np.clip(y0 + dy, 0, size - 1).astype(np.int64)
        out.append((row * size + col, w))
    return out


def _local_mean(acc: np.ndarray, cnt: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian-weighted sums of ``acc`` (S, S, 3) and ``cnt`` (S, S) within ``sigma`` texels."""
    k = 2 * int(np.ceil(3 * sigma)) + 1
    norm = 2 * np.pi * sigma * sigma  # GaussianBlur averages; back to sums of about that many texels
    a = cv2.GaussianBlur(acc, (k, k), sigma, borderType=cv2.BORDER_CONSTANT) * norm
    c = cv2.GaussianBlur(cnt, (k, k), sigma, borderType=cv2.BORDER_CONSTANT) * norm
    return a, c


def shrunk_means(acc: np.ndarray, cnt: np.ndarray, prior_count: float) -> np.ndarray:
    """(S, S, 3) per-texel means of the colour sums ``acc`` (S, S, 3) over the weights ``cnt``
    (S, S), each drawn towards its neighbourhood's by ``prior_count`` pseudo-pixels (module
    docstring); 0 where nothing was seen within the coarsest scale."""
    acc = acc.astype(np.float64)
    cnt = cnt.astype(np.float64)
    prior = None
    for sigma in PRIOR_SIGMAS:
        a, c = _local_mean(acc, cnt, sigma)
        if prior is None:
            prior = a / np.maximum(c, 1e-12)[..., None]
        else:
            prior = (a + prior_count * prior) / (c + prior_count)[..., None]
    return (acc + prior_count * prior) / (cnt + prior_count)[..., None]
