"""``morf bench render``'s report of the CPU and of the kernels onnxruntime ran."""

from __future__ import annotations

import pytest

from morf.bench.render import cpu_report, graph_profile, kernel_summary, op_kind


def test_op_kinds_split_int8_kernels_conversions_float_and_8_bit_data():
    assert op_kind("QLinearConv", ["uint8", "float"]) == "int8"
    assert op_kind("ConvInteger", ["uint8"]) == "int8" and op_kind("MatMulInteger", ["int8"]) == "int8"
    assert op_kind("DequantizeLinear", ["uint8"]) == "conversion"
    assert op_kind("Resize", ["float", "float"]) == "float" and op_kind("Conv", ["float"]) == "float"
    assert op_kind("Concat", ["uint8", "uint8"]) == "8-bit data"


def test_cpu_report_names_the_features_that_matter_for_int8():
    line = cpu_report("Some CPU", 2, {"flags": ["avx2", "avx512f", "avx512_vnni"]})
    assert line == "Some CPU, 2 cores; AMX no, AVX512-BF16 no, VNNI yes (AVX-512), AVX2 yes"
    assert "AMX yes" in cpu_report("X", 8, {"flags": ["amx_int8", "amx_tile"]})


@pytest.fixture(scope="module")
def tiny_player(tmp_path_factory, body_model, gl):
    from types import SimpleNamespace

    from morf.export.synthetic import build_synthetic_avatar, coverage_renderer, coverage_texture
    from morf.playback.player import Player

    out = tmp_path_factory.mktemp("avatar") / "avatar"
    build_synthetic_avatar(out, body_model, renderer=coverage_renderer(), texture=coverage_texture(),
                           renderer_cfg=SimpleNamespace(in_channels=16), image_size=64,
                           calibration_views=4, heldout_views=1, seed=3)
    with Player(out, size=64, ctx=gl.ctx) as p:
        yield p


@pytest.mark.gl
def test_the_profile_finds_the_int8_convolution_and_the_float_compositing(tiny_player):
    import numpy as np

    from morf.raster.camera_paths import front_camera

    raster = tiny_player.rasterize(np.zeros((tiny_player.avatar.skeleton.num_bones, 3), np.float32),
                                   np.zeros(3, np.float32), front_camera(64))
    prof = graph_profile(tiny_player, raster, runs=3)
    assert prof["ops"]["QLinearConv"] == {**prof["ops"]["QLinearConv"], "kind": "int8", "nodes": 1}
    assert sum(prof["kind_share"].values()) == pytest.approx(1.0)
    assert list(prof["ops"].values())[0]["ms"] >= list(prof["ops"].values())[-1]["ms"]  # costliest first
    if tiny_player.renderer.composites:
        assert 0.0 < prof["composite_share"] < 1.0
    assert "int8: " in kernel_summary(prof) and "QLinearConv x1" in kernel_summary(prof)
