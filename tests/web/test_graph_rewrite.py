"""The web-only renderer graph rewrites (morf/web/graph_rewrite.py, morf/web/head_rewrite.py) keep the
outputs: the slice and coverage rewrites bit for bit, the head rewrite to float rounding."""

from __future__ import annotations

import numpy as np
import pytest


def _raster_model(nodes, outputs: list[str], consts) -> bytes:
    """A model of ``nodes`` on a (1, H, W, 16) uint8 ``raster`` input with float ``outputs``."""
    from onnx import TensorProto, helper

    graph = helper.make_graph(nodes, "g", [helper.make_tensor_value_info("raster", TensorProto.UINT8, [1, "height", "width", 16])],
                              [helper.make_tensor_value_info(o, TensorProto.FLOAT, None) for o in outputs], consts)
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]).SerializeToString()


def _graph(axes=(1,)):
    """raster (1, H, W, 16) uint8 -> NCHW transpose -> {a channel slice as float, the whole as float}."""
    from onnx import TensorProto, helper, numpy_helper

    consts = [numpy_helper.from_array(np.array(v, np.int64), n) for n, v in
              (("starts", [0]), ("ends", [3]), ("axes", list(axes)), ("steps", [1]))]
    nodes = [helper.make_node("Transpose", ["raster"], ["nchw"], perm=[0, 3, 1, 2]),
             helper.make_node("Slice", ["nchw", "starts", "ends", "axes", "steps"], ["colour_bytes"], name="colour"),
             helper.make_node("Cast", ["colour_bytes"], ["colour"], to=TensorProto.FLOAT),
             helper.make_node("Cast", ["nchw"], ["all"], to=TensorProto.FLOAT)]
    return _raster_model(nodes, ["colour", "all"], consts)


def test_slice_before_transpose_keeps_the_outputs():
    import onnx
    import onnxruntime as ort

    from morf.web.graph_rewrite import slice_before_transpose

    raw = _graph()
    new = slice_before_transpose(raw)
    g = onnx.load_from_string(new).graph
    sliced = next(n for n in g.node if n.name == "colour_channels_last")
    assert sliced.op_type == "Slice" and sliced.input[0] == "raster"  # the slice reads the NHWC raster itself
    raster = np.random.default_rng(0).integers(0, 256, (1, 24, 40, 16), dtype=np.uint8)
    want = ort.InferenceSession(raw).run(None, {"raster": raster})
    got = ort.InferenceSession(new).run(None, {"raster": raster})
    assert all(np.array_equal(a, b) for a, b in zip(want, got))


@pytest.mark.parametrize("axes", [(2,), (3,)])
def test_slice_before_transpose_leaves_other_slices_alone(axes):
    from morf.web.graph_rewrite import slice_before_transpose

    raw = _graph(axes)
    assert slice_before_transpose(raw) == raw


# ---- the head's rewrite (morf/web/head_rewrite.py): outputs kept to float rounding --------------------

def _matmul_1x1(x: str, w: str, b: str, out: str, tag: str, channels: int) -> list:
    """The exporter's 1 x 1 layer: Reshape(x, [0, 0, -1]) -> MatMul(W, .) -> Add(., b) -> Reshape to
    (N, channels, H, W) of x (the shape taken from Shape(x), as torch.onnx writes it)."""
    from onnx import helper

    def dim(i):
        return [helper.make_node("Gather", [f"{tag}_shape", f"i{i}"], [f"{tag}_g{i}"], axis=0),
                helper.make_node("Unsqueeze", [f"{tag}_g{i}", "axis0"], [f"{tag}_d{i}"])]

    return [helper.make_node("Reshape", [x, "flat"], [f"{tag}_flat"]),
            helper.make_node("MatMul", [w, f"{tag}_flat"], [f"{tag}_mm"]),
            helper.make_node("Add", [f"{tag}_mm", b], [f"{tag}_biased"]),
            helper.make_node("Shape", [x], [f"{tag}_shape"]), *dim(0), *dim(2), *dim(3),
            helper.make_node("Concat", [f"{tag}_d0", f"c{channels}", f"{tag}_d2", f"{tag}_d3"], [f"{tag}_dims"], axis=0),
            helper.make_node("Reshape", [f"{tag}_biased", f"{tag}_dims"], [out])]


def _head_graph(low_channels=16, mid=16, outs=4, after_resize="Add"):
    """A tiny fp32 head as the exporter writes it: low (1, Cl, h, w) -> 1 x 1 (MatMul) -> 2x bilinear
    -> + skip (1, mid, 2h, 2w) -> LeakyRelu -> 1 x 1 (MatMul) -> head (1, outs, 2h, 2w)."""
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(1)
    consts = {"w1": rng.normal(0, 0.3, (mid, low_channels)), "b1": rng.normal(0, 0.3, (1, mid, 1)),
              "w2": rng.normal(0, 0.3, (outs, mid)), "b2": rng.normal(0, 0.3, (1, outs, 1)),
              "scales": [1, 1, 2, 2]}
    inits = [numpy_helper.from_array(np.asarray(v, np.float32), k) for k, v in consts.items()]
    inits += [numpy_helper.from_array(np.array(v, np.int64), k) for k, v in
              (("flat", [0, 0, -1]), ("axis0", [0]), ("i0", 0), ("i2", 2), ("i3", 3), (f"c{mid}", [mid]), (f"c{outs}", [outs]))]
    nodes = _matmul_1x1("low", "w1", "b1", "low_mid", "a", mid)
    nodes.append(helper.make_node("Resize", ["low_mid", "", "scales"], ["up"], mode="linear",
                                  coordinate_transformation_mode="half_pixel"))
    nodes.append(helper.make_node(after_resize, ["up", "skip"], ["summed"]))
    nodes.append(helper.make_node("LeakyRelu", ["summed"], ["act"], alpha=0.2))
    nodes += _matmul_1x1("act", "w2", "b2", "head", "b", outs)
    f = TensorProto.FLOAT
    graph = helper.make_graph(nodes, "head", [helper.make_tensor_value_info("low", f, [1, low_channels, "h", "w"]),
                                              helper.make_tensor_value_info("skip", f, [1, mid, "h2", "w2"])],
                              [helper.make_tensor_value_info("head", f, None)], inits)
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]).SerializeToString()


def _run(graph: bytes, feeds: dict) -> list:
    import onnxruntime as ort

    return ort.InferenceSession(graph, providers=["CPUExecutionProvider"]).run(None, feeds)


def _feeds(low_channels=16, mid=16, h=12, w=20) -> dict:
    rng = np.random.default_rng(2)
    return {"low": rng.normal(0, 1, (1, low_channels, h, w)).astype(np.float32),
            "skip": rng.normal(0, 1, (1, mid, 2 * h, 2 * w)).astype(np.float32)}


def test_head_rewrite_keeps_the_outputs_and_fires():
    import onnx

    from morf.web.head_rewrite import matmul_as_conv, resize_before_conv, rewrite_head

    raw, feeds = _head_graph(), _feeds()
    want = _run(raw, feeds)[0]
    conv = matmul_as_conv(raw)
    new = rewrite_head(raw)
    for g in (conv, new):
        got = _run(g, feeds)[0]
        assert got.shape == want.shape and np.abs(got - want).max() < 1e-5 * np.abs(want).max(), np.abs(got - want).max()
    nodes = onnx.load_from_string(new).graph.node
    ops = [n.op_type for n in nodes]
    assert "MatMul" not in ops and "Reshape" not in ops and "Shape" not in ops and ops.count("Conv") == 2, ops
    resize = next(n for n in nodes if n.op_type == "Resize")
    assert resize.input[0] == "low"  # the resize now reads the 1 x 1 layer's input
    first = next(n for n in nodes if n.op_type == "Conv" and n.input[0] == resize.output[0])
    assert [n.op_type for n in nodes if first.output[0] in n.input] == ["Add"]  # Conv -> Add -> LeakyRelu: one fused kernel
    assert resize_before_conv(conv) == new and matmul_as_conv(new) == new  # each applies once


@pytest.mark.parametrize("case", ["reducing", "not_a_sum"])
def test_resize_stays_where_moving_it_gains_nothing(case):
    from morf.web.head_rewrite import matmul_as_conv, resize_before_conv

    # a 1 x 1 layer from 32 channels to 16: resizing its input would read twice the channels
    raw = _head_graph(low_channels=32) if case == "reducing" else _head_graph(after_resize="Mul")
    conv = matmul_as_conv(raw)
    assert conv != raw and resize_before_conv(conv) == conv
    feeds = _feeds(low_channels=32 if case == "reducing" else 16)
    assert np.abs(_run(conv, feeds)[0] - _run(raw, feeds)[0]).max() < 1e-4


def test_matmul_with_a_foreign_shape_is_left_alone():
    import onnx
    from onnx import numpy_helper

    from morf.web.head_rewrite import matmul_as_conv

    model = onnx.load_from_string(_head_graph())
    for t in model.graph.initializer:
        if t.name == "flat":  # the first reshape flattens N and C together: not a 1 x 1 layer
            t.CopyFrom(numpy_helper.from_array(np.array([0, -1, 1], np.int64), "flat"))
    raw = model.SerializeToString()
    assert matmul_as_conv(raw) == raw


@pytest.fixture(scope="module")
def exported_avatar(tmp_path_factory, body_model):
    """A synthetic avatar exported with the cpu preset's renderer (random weights): the head's real structure."""
    from morf.export.synthetic import build_synthetic_avatar

    out = tmp_path_factory.mktemp("head") / "avatar"
    build_synthetic_avatar(out, body_model=body_model, image_size=64, texture_size=64, calibration_views=3,
                           heldout_views=1)
    return out


@pytest.mark.parametrize("precision", ["int8", "fp32"])
def test_head_rewrite_fires_on_the_exported_graph(exported_avatar, precision):
    import onnx
    import onnxruntime as ort

    from morf.playback.player import load_avatar
    from morf.web.head_rewrite import rewrite_head
    from morf.web.web_avatar import web_renderer

    r = web_renderer(load_avatar(exported_avatar), precision)
    new = rewrite_head(r.graph)
    before = [n.op_type for n in onnx.load_from_string(r.graph).graph.node]
    after = onnx.load_from_string(new).graph.node
    # the int8 export writes the head's 1 x 1 layers as MatMuls (the fp32 one as Conv already)
    assert before.count("MatMul") == (2 if precision == "int8" else 0) and not any(n.op_type == "MatMul" for n in after)
    producers = {o: n for n in after for o in n.output}
    moved = [n for n in after if n.op_type == "Conv" and producers.get(n.input[0]) is not None
             and producers[n.input[0]].op_type == "Resize"]
    assert len(moved) == 1, "the head's resize comes before its first 1 x 1 layer"
    raster = np.random.default_rng(0).integers(0, 256, (1, 128, 192, 16), dtype=np.uint8)
    runs = [ort.InferenceSession(g, providers=["CPUExecutionProvider"]).run(r.contract["outputs"], {r.contract["input"]: raster})
            for g in (r.graph, new)]
    for want, got in zip(*runs):
        assert want.shape == got.shape and np.abs(want - got).max() <= 1e-5 * max(1.0, np.abs(want).max())


def test_the_web_folder_carries_the_rewritten_head(exported_avatar, tmp_path):
    import hashlib
    import json

    import onnx

    from morf.playback.player import load_avatar
    from morf.web.head_rewrite import rewrite_web_renderer
    from morf.web.web_avatar import write_web_avatar

    write_web_avatar(load_avatar(exported_avatar), tmp_path, [])
    rewrite_web_renderer(tmp_path)
    graph = (tmp_path / "renderer.onnx").read_bytes()
    model = onnx.load_from_string(graph)
    ops = [n.op_type for n in model.graph.node]
    # the head rewritten; the colour fill (and with it its coverage test) left to the page
    doc = json.loads((tmp_path / "avatar.json").read_text())
    head = doc["renderer"]["tail"]["head"]
    assert "MatMul" not in ops and "Sign" not in ops and [o.name for o in model.graph.output] == [head]
    assert doc["renderer"]["outputs"] == [head] and doc["renderer"]["tail"]["fill_levels"] == 6
    entry = doc["files"]["renderer.onnx"]
    assert entry == {"bytes": len(graph), "sha256": hashlib.sha256(graph).hexdigest()}


# ---- the fill's coverage test (morf/web/graph_rewrite.py: coverage_by_sign): bit-identical -------------

def _coverage_graph(zero_point=128.0, width=1):
    """raster (1, H, W, 16) uint8 -> colour bytes NCHW -> the exporter's coverage test of channel 0
    (Slice -> Cast -> Sub -> Abs -> Greater -> Cast to float), and the colour bytes as float."""
    from onnx import TensorProto, helper, numpy_helper

    consts = [numpy_helper.from_array(np.array(v, t), n) for n, v, t in
              (("c0", [0], np.int64), ("c3", [3], np.int64), ("ax3", [3], np.int64), ("s", [0], np.int64),
               ("e", [width], np.int64), ("ax1", [1], np.int64), ("zp", zero_point, np.float32), ("zero", 0.0, np.float32))]
    nodes = [helper.make_node("Slice", ["raster", "c0", "c3", "ax3"], ["colour_last"]),
             helper.make_node("Transpose", ["colour_last"], ["colour_bytes"], perm=[0, 3, 1, 2]),
             helper.make_node("Slice", ["colour_bytes", "s", "e", "ax1"], ["byte"]),
             helper.make_node("Cast", ["byte"], ["value"], to=TensorProto.FLOAT),
             helper.make_node("Sub", ["value", "zp"], ["off"]),
             helper.make_node("Abs", ["off"], ["dist"]),
             helper.make_node("Greater", ["dist", "zero"], ["covered_bool"]),
             helper.make_node("Cast", ["covered_bool"], ["covered"], to=TensorProto.FLOAT),
             helper.make_node("Cast", ["colour_bytes"], ["colour"], to=TensorProto.FLOAT)]
    return _raster_model(nodes, ["covered", "colour"], consts)


def test_coverage_by_sign_keeps_the_outputs():
    import onnx

    from morf.web.graph_rewrite import coverage_by_sign

    raw = _coverage_graph()
    new = coverage_by_sign(raw)
    ops = [n.op_type for n in onnx.load_from_string(new).graph.node]
    assert "Greater" not in ops and ops.count("Cast") == 1 and "Sign" in ops and "Gather" in ops, ops
    rng = np.random.default_rng(0)
    raster = rng.integers(0, 256, (1, 24, 40, 16), dtype=np.uint8)
    raster[0, rng.random((24, 40)) < 0.5, 0] = 128  # half the pixels off the body
    raster[0, 0, :3, 0] = (0, 127, 129)  # the bytes next to the zero point and the farthest one
    want, got = _run(raw, {"raster": raster}), _run(new, {"raster": raster})
    assert all(a.dtype == b.dtype and np.array_equal(a, b) for a, b in zip(want, got))
    assert 0 < want[0].mean() < 1


@pytest.mark.parametrize("kw", [{"zero_point": 127.5}, {"width": 2}])
def test_coverage_by_sign_leaves_other_tests_alone(kw):
    from morf.web.graph_rewrite import coverage_by_sign

    raw = _coverage_graph(**kw)
    assert coverage_by_sign(raw) == raw


def test_coverage_by_sign_fires_on_the_exported_graph(exported_avatar):
    """On the cut graph with its colour fill, as the web export keeps it where the page cannot
    compute the fill (morf/web/page_fill.py)."""
    import dataclasses

    import onnx

    from morf.playback.graph_outputs import cut_graph
    from morf.playback.native_tail import spec_for
    from morf.playback.player import load_avatar
    from morf.web.graph_rewrite import coverage_by_sign, slice_before_transpose

    avatar = load_avatar(exported_avatar)
    spec = dataclasses.replace(spec_for(avatar.manifest, "int8"), head_stage=None)
    graph = slice_before_transpose(cut_graph(avatar.renderer_path("int8").read_bytes(), spec.cut))
    new = coverage_by_sign(graph)
    assert [n.op_type for n in onnx.load_from_string(new).graph.node].count("Sign") == 1
    raster = np.random.default_rng(1).integers(120, 137, (1, 128, 192, 16), dtype=np.uint8)
    name = avatar.manifest["renderer"]["input"]
    want, got = _run(graph, {name: raster}), _run(new, {name: raster})
    assert all(np.array_equal(a, b) for a, b in zip(want, got))
