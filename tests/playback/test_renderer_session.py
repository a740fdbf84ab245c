"""The player's renderer session: it runs the graph without the ``rgba`` output it never fetches
(trimmed from the model's bytes by :mod:`morf.playback.graph_outputs`), and gives the same image as
the whole graph."""

import numpy as np
import onnx
import onnxruntime as ort
import pytest

from morf.errors import InputError
from morf.playback.graph_outputs import encode_varint, fields, keep_outputs
from morf.playback.onnx_renderer import OnnxRenderer, background_planes, image_only_graph

SIZE = 128  # as in conftest.py


def _raster(session, seed=0):
    shape = [d if isinstance(d, int) else SIZE for d in session.get_inputs()[0].shape]
    shape[0] = 1
    return np.random.default_rng(seed).integers(90, 170, shape).astype(np.uint8)


@pytest.mark.parametrize("precision", ["int8", "fp32"])
def test_the_image_only_graph_matches_the_whole_graph(tiny_avatar, precision):
    path = tiny_avatar / ("renderer_int8.onnx" if precision == "int8" else "renderer.onnx")
    whole = onnx.load(str(path))
    lean = onnx.load_from_string(image_only_graph(path))
    assert [o.name for o in lean.graph.output] == ["image"]
    assert len(lean.graph.node) <= len(whole.graph.node)
    full = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    raster = _raster(full)
    bg = background_planes((10, 200, 30), SIZE)
    want = full.run(["image"], {full.get_inputs()[0].name: raster, "background": bg})[0][0]
    r = OnnxRenderer(path)
    assert [o.name for o in r.session.get_outputs()] == ["image"]
    assert np.array_equal(r.image(raster, bg), want)
    # rgba, which playback never asks for, still comes from the whole graph
    rgba = r(raster)
    assert rgba.shape == (1, 4, SIZE, SIZE)
    assert np.array_equal(rgba, full.run(["rgba"], {full.get_inputs()[0].name: raster,
                                                    "background": np.zeros((1, 3, 1, 1), np.float32)})[0])


@pytest.mark.parametrize("precision", ["int8", "fp32"])
def test_a_session_for_one_image_size_gives_the_same_image(tiny_avatar, precision):
    """The player fixes the graph's image dimensions to its size (onnxruntime then folds the
    resizes' shape arithmetic); the image stays the same."""
    path = tiny_avatar / ("renderer_int8.onnx" if precision == "int8" else "renderer.onnx")
    free, fixed = OnnxRenderer(path), OnnxRenderer(path, size=SIZE)
    assert fixed.session.get_inputs()[0].shape[1:3] == [SIZE, SIZE]
    assert free.session.get_inputs()[0].shape[1:3] == ["height", "width"]
    raster = _raster(free.session, seed=2)
    bg = background_planes((10, 200, 30), SIZE)
    assert np.array_equal(fixed.image(raster, bg), free.image(raster, bg))
    with pytest.raises(Exception):  # another size no longer fits the session
        fixed.image(np.zeros((1, SIZE // 2, SIZE // 2, raster.shape[3]), np.uint8), background_planes((0, 0, 0), SIZE // 2))


def test_the_nodes_that_fed_only_rgba_are_dropped(tmp_path):
    from onnx import TensorProto, helper

    from morf.export.onnx_graph import append_composite

    x = helper.make_tensor_value_info("raster", TensorProto.FLOAT, [1, 4, 2, 2])
    y = helper.make_tensor_value_info("rgba", TensorProto.FLOAT, [1, 4, 2, 2])
    split = helper.make_tensor("split", TensorProto.INT64, [2], [3, 1])
    nodes = [helper.make_node("Split", ["raster", "split"], ["rgb", "mask"], axis=1),
             helper.make_node("Concat", ["rgb", "mask"], ["rgba"], axis=1)]
    model = helper.make_model(helper.make_graph(nodes, "g", [x], [y], [split]),
                              opset_imports=[helper.make_opsetid("", 17)])
    path = tmp_path / "r.onnx"
    onnx.save(append_composite(model), str(path))
    lean = onnx.load_from_string(image_only_graph(path))
    assert "Concat" not in [n.op_type for n in lean.graph.node] and "Split" in [n.op_type for n in lean.graph.node]
    raster = np.random.default_rng(1).random((1, 4, 2, 2)).astype(np.float32) * 0.5
    r = OnnxRenderer(path)
    bg = background_planes((0, 0, 255), 2)
    want = np.clip(np.round(255 * raster[0, :3] + (1 - raster[0, 3:]) * bg[0]), 0, 255).transpose(1, 2, 0)
    assert np.abs(r.image(raster, bg).astype(int) - want).max() <= 1
    assert np.array_equal(r(raster), raster)


def test_a_graph_without_compositing_is_left_whole(tmp_path):
    from onnx import TensorProto, helper

    x = helper.make_tensor_value_info("raster", TensorProto.FLOAT, [1, 4, 2, 2])
    y = helper.make_tensor_value_info("rgba", TensorProto.FLOAT, [1, 4, 2, 2])
    g = helper.make_graph([helper.make_node("Identity", ["raster"], ["rgba"])], "g", [x], [y])
    path = tmp_path / "r.onnx"
    onnx.save(helper.make_model(g, opset_imports=[helper.make_opsetid("", 17)]), str(path))
    assert image_only_graph(path) is None
    r = OnnxRenderer(path)
    assert not r.composites
    x = np.ones((1, 4, 2, 2), np.float32)
    assert np.array_equal(r(x), x)


def test_a_damaged_renderer_is_a_user_error(tmp_path):
    path = tmp_path / "renderer_int8.onnx"
    path.write_bytes(b"not a graph")
    with pytest.raises(InputError, match="cannot load renderer"):
        OnnxRenderer(path)


def _onnx_pruned(model: onnx.ModelProto, keep) -> onnx.ModelProto:
    """The same trim with the onnx package, as the reference."""
    g = model.graph
    outs = [o for o in g.output if o.name in keep]
    del g.output[:]
    g.output.extend(outs)
    while True:
        used = {i for n in g.node for i in n.input} | {o.name for o in g.output}
        dead = [n for n in g.node if not any(o in used for o in n.output)]
        if not dead:
            return model
        for n in dead:
            g.node.remove(n)


def test_the_byte_trim_equals_the_onnx_packages(tiny_avatar):
    path = tiny_avatar / "renderer_int8.onnx"
    data = path.read_bytes()
    assert [o.name for o in onnx.load(str(path)).graph.output] == ["rgba", "image"]
    ours = onnx.load_from_string(keep_outputs(data, ["image"]))
    ref = _onnx_pruned(onnx.load(str(path)), ["image"])
    assert ours.SerializeToString() == ref.SerializeToString()
    # keeping rgba alone drops the compositing instead
    alone = onnx.load_from_string(keep_outputs(data, ["rgba"]))
    assert not any(n.name.startswith("composite_") for n in alone.graph.node)
    assert alone.SerializeToString() == _onnx_pruned(onnx.load(str(path)), ["rgba"]).SerializeToString()


def test_nothing_to_trim_or_no_such_output_leaves_the_model_alone(tiny_avatar):
    data = (tiny_avatar / "renderer_int8.onnx").read_bytes()
    assert keep_outputs(data, ["rgba", "image"]) is None
    assert keep_outputs(data, ["nope"]) is None


def test_control_flow_graphs_are_left_whole():
    from onnx import TensorProto, helper

    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])
    then = helper.make_graph([helper.make_node("Identity", ["x"], ["t"])], "then", [],
                             [helper.make_tensor_value_info("t", TensorProto.FLOAT, [1])])
    cond = helper.make_tensor_value_info("c", TensorProto.BOOL, [])
    nodes = [helper.make_node("If", ["c"], ["a"], then_branch=then, else_branch=then),
             helper.make_node("Identity", ["x"], ["b"])]
    outs = [helper.make_tensor_value_info(n, TensorProto.FLOAT, [1]) for n in ("a", "b")]
    data = helper.make_model(helper.make_graph(nodes, "g", [x, cond], outs)).SerializeToString()
    assert keep_outputs(data, ["b"]) is None


_UNNAMED_OUTPUT = encode_varint(12 << 3 | 2) + encode_varint(0)  # GraphProto.output: an empty ValueInfoProto
_GRAPH = encode_varint(7 << 3 | 2) + encode_varint(len(_UNNAMED_OUTPUT)) + _UNNAMED_OUTPUT


@pytest.mark.parametrize("data", [b"", b"not a graph", encode_varint(7 << 3 | 2) + encode_varint(99) + b"short",
                                  _GRAPH, bytes([0xFF] * 12)])
def test_bytes_that_are_not_a_model_raise(data):
    with pytest.raises(ValueError):
        keep_outputs(data, ["image"])


def test_varints_round_trip():
    for v in (0, 1, 127, 128, 300, 2**31, 2**63 - 1):
        f = fields(encode_varint(1 << 3 | 0) + encode_varint(v))
        assert len(f) == 1 and f[0].number == 1
