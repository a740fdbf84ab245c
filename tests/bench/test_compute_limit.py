"""The renderer's MAC count and the int8 GEMM timings behind `morf bench render`'s compute limit."""

import math

from morf.bench.compute_limit import compute_limit, ort_int8_gemm_gmacs, renderer_macs

TINY = {"in_channels": 4, "width": 4, "depth": 2, "max_width": 8, "stem": 2, "skip_hidden": 4}


def test_macs_follow_the_frame_area_and_the_gemm_rates_are_real():
    from morf.avatar.renderer import RendererConfig

    assert RendererConfig(**TINY)  # a valid config
    small, big = renderer_macs(TINY, 32), renderer_macs(TINY, 64)
    assert small > 0 and big == 4 * small  # every layer's output area grows with the frame's
    rate = ort_int8_gemm_gmacs(64, 32, 16, threads=1, seconds=0.05)
    assert math.isfinite(rate) and rate > 0
    lim = compute_limit(TINY, 32, renderer_ms=1.0, threads=1, seconds=0.05)
    assert lim["renderer_gmacs_per_frame"] == small / 1e9
    assert math.isclose(lim["fraction_of_limit"] * lim["best_gemm_gmacs"], lim["renderer_gmacs_achieved"])
    assert math.isclose(lim["fps_at_limit"], lim["best_gemm_gmacs"] / lim["renderer_gmacs_per_frame"])
