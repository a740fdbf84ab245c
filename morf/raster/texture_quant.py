"""Neural texture quantisation to uint8: the texture the GL neural rasterizer samples
(:mod:`morf.raster.neural_raster`) and the exported avatar stores (``texture.npz``).

Per-channel symmetric scales with one common zero point 128: ``value = (q - 128) * scale[c]``.
A value of 0 (the renderer's background) is exactly 128 in every channel, so the GL framebuffer
cleared to 128 means "no body" without any per-channel constant. Bilinear sampling of the uint8
texels followed by re-quantisation in an 8-bit framebuffer then equals sampling the dequantised
texture in torch and re-quantising (within one LSB of filter rounding).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ZERO_POINT = 128


@dataclass(frozen=True)
class QuantizedTexture:
    """A neural texture stored as bytes.

    Fields:
        data: (Ht, Wt, C) uint8, row 0 = top of the atlas (v = 1), values in [1, 255].
        scales: (C,) float32, ``value = (data - 128) * scales``.
    """

    data: np.ndarray
    scales: np.ndarray

    @property
    def channels(self) -> int:
        return int(self.data.shape[2])

    def dequantize(self) -> np.ndarray:
        """(C, Ht, Wt) float32 texture as the torch side sees it."""
        return dequantize_texture(self.data, self.scales)


def quantize_texture(texture: np.ndarray, min_peak: np.ndarray | None = None) -> QuantizedTexture:
    """Quantise a (C, Ht, Wt) float texture (row 0 = top) to uint8 with per-channel scales.

    ``scales[c] = max|texture[c]| / 127`` so the channel's range maps onto [1, 255]; ``min_peak``
    (C,) raises a channel's peak to cover values other textures will put there (view colours).
    """
    tex = np.asarray(texture, dtype=np.float32)
    if tex.ndim != 3:
        raise ValueError(f"neural texture must be (C, H, W), got {tex.shape}")
    if not np.isfinite(tex).all():
        raise ValueError("neural texture holds NaN or inf")
    peak = np.abs(tex).reshape(tex.shape[0], -1).max(axis=1)
    if min_peak is not None:
        peak = np.maximum(peak, np.asarray(min_peak, np.float32))
    # An all-zero channel still needs a positive scale; any value works, 1/127 keeps it tidy.
    scales = np.where(peak > 0, peak, 1.0).astype(np.float32) / 127.0
    return QuantizedTexture(data=texture_bytes(tex.transpose(1, 2, 0), scales), scales=scales.astype(np.float32))


def texture_bytes(values: np.ndarray, scales: np.ndarray, zero_point: int = ZERO_POINT) -> np.ndarray:
    """(..., C) float values, channels last, in a texture's bytes: rounded to ``scales`` (C,) steps
    about ``zero_point`` and clipped to its +-127 (the texture's own, and the colours by view laid
    into it)."""
    q = np.rint(np.asarray(values, np.float32) / np.asarray(scales, np.float32)) + zero_point
    return np.ascontiguousarray(np.clip(q, zero_point - 127, zero_point + 127).astype(np.uint8))


def dequantize_texture(data: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """(Ht, Wt, C) uint8 + (C,) scales -> (C, Ht, Wt) float32."""
    d = np.asarray(data).astype(np.float32) - ZERO_POINT
    return np.ascontiguousarray((d * np.asarray(scales, np.float32)).transpose(2, 0, 1))


def sinusoid_texture(channels: int = 16, size: int = 256, seed: int = 0) -> np.ndarray:
    """A smooth random (C, size, size) float32 texture: sums of low-frequency sinusoids per channel.

    Used where no trained texture exists (benchmarks, tests): speed does not depend on its values,
    and its smoothness makes bilinear comparisons meaningful.
    """
    rng = np.random.default_rng(seed)
    yy, xx = np.meshgrid(np.linspace(0, 1, size, dtype=np.float32), np.linspace(0, 1, size, dtype=np.float32),
                         indexing="ij")
    out = np.zeros((channels, size, size), np.float32)
    for c in range(channels):
        for _ in range(4):
            fx, fy = rng.uniform(1, 12, size=2)
            phase = rng.uniform(0, 2 * np.pi)
            out[c] += rng.uniform(0.2, 1.0) * np.sin(2 * np.pi * (fx * xx + fy * yy) + phase).astype(np.float32)
    return out
