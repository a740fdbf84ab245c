"""uint8 neural texture: round trip, zero point, degenerate channels."""

import numpy as np
import pytest

from morf.raster.texture_quant import ZERO_POINT, dequantize_texture, quantize_texture, sinusoid_texture


def test_round_trip_within_half_step():
    tex = sinusoid_texture(16, 32, seed=3) * np.linspace(0.1, 3.0, 16, dtype=np.float32)[:, None, None]
    q = quantize_texture(tex)
    assert q.data.shape == (32, 32, 16) and q.data.dtype == np.uint8
    err = np.abs(q.dequantize() - tex)
    assert np.all(err <= q.scales[:, None, None] / 2 + 1e-6)
    assert q.data.min() >= 1  # symmetric: -max maps to 1, +max to 255
    np.testing.assert_allclose(np.abs(q.dequantize()).reshape(16, -1).max(1), np.abs(tex).reshape(16, -1).max(1),
                               rtol=1e-5)


def test_zero_is_the_common_zero_point():
    tex = np.zeros((16, 4, 4), np.float32)
    tex[3] = 5.0
    q = quantize_texture(tex)
    assert np.all(q.data[..., [c for c in range(16) if c != 3]] == ZERO_POINT)
    assert np.all(q.data[..., 3] == 255)
    assert np.all(dequantize_texture(q.data, q.scales)[0] == 0)


def test_rejects_bad_textures():
    with pytest.raises(ValueError):
        quantize_texture(np.zeros((4, 4)))
    bad = np.zeros((2, 4, 4), np.float32)
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError):
        quantize_texture(bad)
