"""The web-only renderer graph rewrites (morf/web/graph_rewrite.py) leave every output bit-identical."""

from __future__ import annotations

import numpy as np
import pytest


def _graph(axes=(1,)):
    """raster (1, H, W, 16) uint8 -> NCHW transpose -> {a channel slice as float, the whole as float}."""
    from onnx import TensorProto, helper, numpy_helper

    consts = [numpy_helper.from_array(np.array(v, np.int64), n) for n, v in
              (("starts", [0]), ("ends", [3]), ("axes", list(axes)), ("steps", [1]))]
    nodes = [helper.make_node("Transpose", ["raster"], ["nchw"], perm=[0, 3, 1, 2]),
             helper.make_node("Slice", ["nchw", "starts", "ends", "axes", "steps"], ["colour_bytes"], name="colour"),
             helper.make_node("Cast", ["colour_bytes"], ["colour"], to=TensorProto.FLOAT),
             helper.make_node("Cast", ["nchw"], ["all"], to=TensorProto.FLOAT)]
    graph = helper.make_graph(nodes, "g", [helper.make_tensor_value_info("raster", TensorProto.UINT8, [1, "height", "width", 16])],
                              [helper.make_tensor_value_info("colour", TensorProto.FLOAT, None),
                               helper.make_tensor_value_info("all", TensorProto.FLOAT, None)], consts)
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]).SerializeToString()


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
