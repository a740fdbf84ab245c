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
    rgb = np.moveaxis(x[:3], 0, -1)  # a view; the arithmetic below makes the one copy
    inv = 1.0 - x[3][..., None]
    bg = np.asarray(background, np.float32) * (1.0 / 255.0)
    out = rgb + inv * bg
    return (np.clip(out, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
