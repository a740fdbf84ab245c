"""Compositing the renderer's premultiplied RGB over a background (torch-free)."""

from __future__ import annotations

import numpy as np


def composite(rgba: np.ndarray, background: np.ndarray | tuple) -> np.ndarray:
    """Premultiplied RGB + mask over a background.

    Args:
        rgba: (1, 4, H, W) float32: RGB premultiplied by the mask, then the mask in [0, 1].
        background: (H, W, 3) uint8 image or an RGB colour triple (0-255).
    Returns:
        (H, W, 3) uint8 ``rgb + (1 - mask) * background``.
    """
    x = rgba[0]
    _, H, W = x.shape
    bg = np.asarray(background, np.float32)
    # Work on contiguous channel planes (the renderer's layout) and interleave only the final
    # bytes: arithmetic on the strided HWC view of a float CHW array is several times slower.
    inv = 1.0 - x[3]
    out = np.empty((3, H, W), np.float32)
    for c in range(3):
        b = bg[..., c] if bg.ndim == 3 else bg[c]
        np.multiply(inv, b, out=out[c])
        out[c] += x[c] * 255.0
    np.clip(out, 0.0, 255.0, out=out)
    out += 0.5
    return np.ascontiguousarray(out.astype(np.uint8).transpose(1, 2, 0))
