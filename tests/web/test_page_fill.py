"""The colour fill's pyramid out of the web graph (morf/web/page_fill.py): the level count is read
off the graph's own output, the Python reference matches the graph's fill and the graph's other
output is unchanged without it; a graph whose fill does not match, or windows that would not halve
exactly, keep the fill in the graph. (The page's JavaScript fill against this reference:
tests/web/test_web_page.py.)"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest


@pytest.fixture(scope="module")
def cut(tail_avatar):
    from morf.export.avatar_folder import load_exported_avatar
    from morf.playback.graph_outputs import cut_graph
    from morf.playback.native_tail import spec_for

    avatar = load_exported_avatar(tail_avatar)
    spec = dataclasses.replace(spec_for(avatar.manifest, "int8"), head_stage=None)  # cut at the head, as the web export
    return cut_graph(avatar.renderer_path("int8").read_bytes(), spec.cut), spec


def _run(graph: bytes, names: list[str], raster: np.ndarray) -> list[np.ndarray]:
    import onnxruntime as ort

    session = ort.InferenceSession(graph, providers=["CPUExecutionProvider"])
    return session.run(names, {session.get_inputs()[0].name: raster[None]})


def test_the_reference_matches_the_graphs_fill_on_a_body_raster(cut):
    from morf.web.page_fill import fill_levels_of, fill_pyramid

    graph, spec = cut
    levels = fill_levels_of(graph, spec)
    assert levels == 6  # traced to reach as far as at 640 px (morf/export/onnx_renderer.py)
    rng = np.random.default_rng(1)
    raster = np.full((128, 192, 16), spec.zero_point, np.uint8)
    yy, xx = np.mgrid[:128, :192]
    body = (yy - 64) ** 2 / 50 ** 2 + (xx - 90) ** 2 / 30 ** 2 < 1  # an ellipse, not a rectangle
    raster[body] = rng.integers(0, 256, (int(body.sum()), 16))
    raster[body, spec.coverage_channel] |= 1  # never the zero point (128) on the body
    (got,) = _run(graph, [spec.fill], raster)
    want = fill_pyramid(raster, spec.colour_scale, spec.zero_point, spec.coverage_channel, levels)
    assert got.shape == (1, *want.shape) and np.abs(got[0] - want).max() <= 1e-5
    # the fill reaches off the body: a covered neighbourhood's colour, with its weight
    assert (want[3][~body[::2, ::2]] > 0).mean() > 0.9


def test_without_fill_drops_the_output_and_keeps_the_head(cut):
    from morf.web.page_fill import probe_raster, without_fill

    graph, spec = cut
    new, levels = without_fill(graph, spec, size_multiple=64)
    assert levels == 6 and len(new) < len(graph)
    raster = probe_raster(spec.zero_point, spec.coverage_channel, seed=2)
    (before,) = _run(graph, [spec.head], raster)
    (after,) = _run(new, [spec.head], raster)
    assert np.array_equal(before, after)
    import onnx

    outputs = [o.name for o in onnx.load_from_string(new).graph.output]
    ops = {n.op_type for n in onnx.load_from_string(new).graph.node}
    assert outputs == [spec.head] and "AveragePool" not in ops


def test_a_fill_that_does_not_match_or_windows_that_do_not_halve_stay_in_the_graph(cut):
    from morf.web.page_fill import without_fill

    graph, spec = cut
    wrong = dataclasses.replace(spec, colour_scale=tuple(2 * c for c in spec.colour_scale))
    assert without_fill(graph, wrong, size_multiple=64) == (graph, None)
    assert without_fill(graph, spec, size_multiple=32) == (graph, None)  # 2**6 does not divide 32


def test_fill_pyramid_refuses_a_raster_that_does_not_halve():
    from morf.web.page_fill import fill_pyramid

    with pytest.raises(ValueError, match="does not halve"):
        fill_pyramid(np.zeros((96, 64, 16), np.uint8), (1, 1, 1), 128, 0, 6)
