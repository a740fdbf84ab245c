"""``morf bench render``'s report of the CPU and of the kernels onnxruntime ran."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from morf.bench.render import cpu_report, graph_profile, int8_line, kernel_summary, op_kind
from morf.bench.render_results import GraphProfile, MeasuredAvatar, OpTime, PlaybackMeasurement, RenderResult


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
def tiny_player(tiny_avatar, gl):
    """The session's tiny exported avatar, played: any int8 avatar serves the profile's checks. The
    session's context is made current for the module: a test run before it on this worker may have
    left another context current (a studio window's), where the player's buffers cannot be made."""
    from morf.playback.player import Player
    from morf.raster.gl_context import current

    with current(gl), Player(tiny_avatar, size=64, ctx=gl.ctx) as p:
        yield p


@pytest.mark.gl
def test_the_profile_finds_the_int8_convolution_and_the_float_compositing(tiny_player):
    import numpy as np

    from morf.raster.camera_paths import front_camera

    raster = tiny_player.rasterize(np.zeros((tiny_player.avatar.skeleton.num_bones, 3), np.float32),
                                   np.zeros(3, np.float32), front_camera(64))
    prof = graph_profile(tiny_player, raster, runs=3)
    conv = prof.ops["QLinearConv"]
    assert conv.kind == "int8" and conv.nodes == 1
    assert sum(prof.kind_share.values()) == pytest.approx(1.0)
    assert list(prof.ops.values())[0].ms >= list(prof.ops.values())[-1].ms  # costliest first
    if tiny_player.renderer.composites:
        assert 0.0 < prof.composite_share < 1.0
    assert "int8: " in kernel_summary(prof) and "QLinearConv x1" in kernel_summary(prof)
    assert GraphProfile.from_dict(json.loads(json.dumps(prof.to_dict()))) == prof  # as the measuring child sends it


def _measurement(composite_share: float | None, tail: str = "graph", raster: str = "gl") -> dict:
    """A measurement as the measuring child writes it (the keys in its order)."""
    kernels = {"ops": {"QLinearConv": {"kind": "int8", "nodes": 3, "ms": 2.5},
                       "Mul": {"kind": "float", "nodes": 1, "ms": 0.5}},
               "kind_share": {"int8": 2.5 / 3, "float": 0.5 / 3}, "composite_share": composite_share}
    d = {"breakdown_ms": {"raster_ms": 1.0, "renderer_ms": 4.0}, "renderer_only_ms": 5.0, "peak_rss_mb": 300.0,
         "kernels": kernels}
    if composite_share is not None:
        d["composite_share_of_graph"] = composite_share
    d.update(threads=2, frame_ms=10.0, fps_end_to_end=100.0, frame_ms_pipelined=8.0, fps_pipelined=125.0,
             int8_psnr_vs_fp32_image_db=41.5, tail=tail, raster=raster)
    if composite_share is None:  # records from before the person's PSNR was measured have none
        d["int8_psnr_vs_fp32_person_db"] = 30.5
    return d


@pytest.mark.parametrize("share,tail,raster", [(None, "compiled:omp", "cpu"), (0.25, "graph", "gl")])
def test_a_measurement_reads_back_as_the_child_wrote_it(share, tail, raster):
    d = _measurement(share, tail, raster)
    m = PlaybackMeasurement.from_dict(json.loads(json.dumps(d)))
    assert json.dumps(m.to_dict()) == json.dumps(d)  # same keys, same order
    assert m.composite_share_of_graph == share and m.kernels.ops["QLinearConv"] == OpTime("int8", 3, 2.5)
    assert m.kernels.composite_share == share and m.tail == tail and m.raster == raster
    assert m.int8_psnr_vs_fp32_person_db == (30.5 if share is None else None)


def test_int8_against_fp32_scores_the_image_and_the_person_apart():
    from morf.bench.render import int8_against_fp32

    white = np.full((20, 20, 3), 255, np.uint8)
    black = np.zeros((20, 20, 3), np.uint8)
    white[5:15, 5:15] = black[5:15, 5:15] = 100  # an opaque person of 100 pixels
    white[15, 5:15], black[15, 5:15] = 200, 100  # a half-covered edge row (coverage 0.6): counted
    white[16, 5:15], black[16, 5:15] = 250, 20  # coverage 0.1: background
    int8 = white.copy()
    int8[5:15, 5:15] = 110  # off by 10 levels over the opaque person only
    image_db, person_db = int8_against_fp32([int8], [white], [black])
    assert person_db == pytest.approx(-10 * np.log10((10 / 255) ** 2 * 100 / 110), abs=1e-4)
    assert image_db == pytest.approx(-10 * np.log10((10 / 255) ** 2 * 100 / 400), abs=1e-4)


def test_the_render_result_keeps_its_keys_and_takes_the_headline_from_the_main_avatar():
    manifest = {"int8_quality": {"psnr_db": 38.0, "ssim": 0.97}, "renderer": {"config": None, "input_layout": "nhwc"}}
    fast = MeasuredAvatar.from_manifest(PlaybackMeasurement.from_dict(_measurement(0.25)), manifest)
    assert list(fast.to_dict())[-5:] == ["int8_psnr_vs_fp32_db", "int8_ssim_vs_fp32", "renderer_config", "input_layout",
                                         "int8_check_db"]
    assert fast.int8_check_db == 38.0  # the lowest of every check the manifest has
    closer = {**manifest, "int8_quality": {"psnr_db": 50.0, "ssim": 0.99, "psnr_person_db": 44.0,
                                           "playback_scale": {"zoom": 2.0, "psnr_db": 47.0, "psnr_person_db": 36.0}}}
    measured = MeasuredAvatar.from_manifest(PlaybackMeasurement.from_dict(_measurement(0.25)), closer)
    assert measured.int8_check_db == 36.0 and "which the player goes by: 36.0 dB" in int8_line(measured, 640)
    assert fast.table_row("a") == {"avatar": "a", "renderer ms": 5.0, "frame ms": 10.0, "fps": 100.0,
                                   "fps pipelined": 125.0, "int8 PSNR dB": 38.0, "peak RSS MB": 300.0,
                                   "tail": "graph"}
    r = RenderResult(size=640, threads=2, frames=60, machine={"cpu": "x"}, cpu_features={}, command="morf bench render",
                     avatar="given", main="given", avatars={"given": fast}, seconds=1.5)
    d = r.to_dict()
    assert list(d) == ["benchmark", "size", "precision", "threads", "frames", "machine", "cpu_features", "command",
                       "avatar", "fps", "fps_pipelined", "pipeline_gain_ms", "breakdown_ms", "peak_rss_mb",
                       "int8_psnr_vs_fp32", "int8_ssim_vs_fp32", "int8_psnr_vs_fp32_image", "int8_psnr_vs_fp32_person",
                       "kernels", "avatars",
                       "seconds"]  # no compute_limit without a renderer config
    assert d["fps"] == 100.0 and d["pipeline_gain_ms"] == 2.0 and d["int8_psnr_vs_fp32"] == 38.0
    assert d["avatars"]["given"] == fast.to_dict() and d["kernels"] == _measurement(0.25)["kernels"]
    limited = replace(r, compute_limit={"fps_at_limit": 90.0}).to_dict()
    assert list(limited)[-1] == "compute_limit"
    assert isinstance(GraphProfile.from_dict(d["kernels"]).ops["Mul"], OpTime)
