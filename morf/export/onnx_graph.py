"""Small ONNX graph edits used by the exporter (pure onnx, no torch).

* :func:`fold_input_scale`: a per-channel ``Mul`` right after the input is folded into the
  weights of the convolutions that read it (directly or through a channel ``Concat``), so the
  dequantisation of the uint8 neural rasterization costs nothing at run time and zero padding
  stays exact (padding happens after the scale in both cases).
* :func:`uint8_input`: the graph takes the GL read-back bytes directly, in one of two layouts.
"""

from __future__ import annotations

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from morf.export.texture_quant import ZERO_POINT

LAYOUTS = ("nchw", "planes")  # (1, 16, H, W) or the four read-back attachments (4, H, W, 4)


def _initializers(model: onnx.ModelProto) -> dict[str, onnx.TensorProto]:
    return {t.name: t for t in model.graph.initializer}


def _consumers(model: onnx.ModelProto, name: str) -> list[onnx.NodeProto]:
    return [n for n in model.graph.node if name in n.input]


def _const_value(model: onnx.ModelProto, name: str) -> np.ndarray | None:
    inits = _initializers(model)
    if name in inits:
        return numpy_helper.to_array(inits[name])
    for n in model.graph.node:
        if n.op_type == "Constant" and n.output[0] == name:
            return numpy_helper.to_array(n.attribute[0].t)
    return None


def _scale_conv_inputs(model: onnx.ModelProto, conv: onnx.NodeProto, scale: np.ndarray, offset: int) -> bool:
    """Multiply input channels [offset, offset + len(scale)) of ``conv``'s weight by ``scale``."""
    inits = _initializers(model)
    if conv.op_type != "Conv" or len(conv.input) < 2 or conv.input[1] not in inits:
        return False
    if any(a.name == "group" and a.i != 1 for a in conv.attribute):
        return False
    if sum(conv.input[1] in n.input for n in model.graph.node) != 1:
        return False  # a shared weight would be scaled twice
    w = numpy_helper.to_array(inits[conv.input[1]]).copy()
    w[:, offset:offset + len(scale)] *= scale[None, :, None, None].astype(w.dtype)
    inits[conv.input[1]].CopyFrom(numpy_helper.from_array(w, conv.input[1]))
    return True


def fold_input_scale(model: onnx.ModelProto, input_name: str) -> bool:
    """Fold ``Mul(input, const (1, C, 1, 1))`` into the consuming convolutions, in place.

    Returns True when folded; False leaves the graph unchanged (still correct, a little slower).
    """
    muls = [n for n in _consumers(model, input_name) if n.op_type == "Mul"]
    if len(muls) != 1 or len(_consumers(model, input_name)) != 1:
        return False
    mul = muls[0]
    other = mul.input[1] if mul.input[0] == input_name else mul.input[0]
    s = _const_value(model, other)
    if s is None or s.ndim != 4 or s.shape[0] != 1 or s.shape[2:] != (1, 1):
        return False
    scale = s.reshape(-1)
    inferred = onnx.shape_inference.infer_shapes(model)
    channels = {vi.name: vi.type.tensor_type.shape.dim[1].dim_value
                for vi in list(inferred.graph.value_info) + list(inferred.graph.input)
                if len(vi.type.tensor_type.shape.dim) == 4}
    plan = []  # (conv, offset)
    for node in _consumers(model, mul.output[0]):
        if node.op_type == "Conv" and node.input[0] == mul.output[0]:
            plan.append((node, 0))
        elif node.op_type == "Concat" and all(a.i in (1, -3) for a in node.attribute if a.name == "axis"):
            offset = 0
            for name in node.input:
                if name == mul.output[0]:
                    break
                if not channels.get(name):
                    return False
                offset += channels[name]
            convs = _consumers(model, node.output[0])
            if not convs or any(c.op_type != "Conv" or c.input[0] != node.output[0] for c in convs):
                return False
            plan += [(c, offset) for c in convs]
        else:
            return False
    backup = [onnx.TensorProto() for _ in model.graph.initializer]
    for b, t in zip(backup, model.graph.initializer):
        b.CopyFrom(t)
    if not all(_scale_conv_inputs(model, conv, scale, off) for conv, off in plan):
        del model.graph.initializer[:]
        model.graph.initializer.extend(backup)
        return False
    for node in _consumers(model, mul.output[0]):
        for i, name in enumerate(node.input):
            if name == mul.output[0]:
                node.input[i] = input_name
    model.graph.node.remove(mul)
    if not _consumers(model, other):
        for t in list(model.graph.initializer):
            if t.name == other:
                model.graph.initializer.remove(t)
    return True


def uint8_input(model: onnx.ModelProto, float_input: str, layout: str, new_name: str = "raster",
                quantized: bool = False) -> onnx.ModelProto:
    """Make the graph read uint8 bytes instead of the float input ``x = (q - 128) / 127``.

    ``quantized=False`` (fp32 graph): a ``DequantizeLinear(1/127, 128)`` is inserted.
    ``quantized=True`` (QDQ graph whose input ``QuantizeLinear`` already uses exactly 1/127 and
    128): that ``QuantizeLinear`` is removed, its consumers read the bytes directly.
    ``layout``: "nchw" reads (1, 16, H, W); "planes" reads the four GL attachments (4, H, W, 4)
    and rearranges them in the graph (a uint8 transpose, 4x cheaper than on floats).
    """
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}")
    g = model.graph
    old = next(i for i in g.input if i.name == float_input)
    nchw = f"{new_name}_nchw" if layout == "planes" else new_name
    new_nodes = []
    if quantized:
        q = [n for n in _consumers(model, float_input) if n.op_type == "QuantizeLinear"]
        if len(q) != 1 or len(_consumers(model, float_input)) != 1:
            raise ValueError("expected one QuantizeLinear on the renderer input")
        sc, zp = _const_value(model, q[0].input[1]), _const_value(model, q[0].input[2])
        if zp is None or zp.dtype != np.uint8 or int(zp) != ZERO_POINT or not np.isclose(float(sc), 1 / 127, rtol=1e-6):
            raise ValueError(f"input quantisation is scale {sc} zero point {zp}, expected 1/127 and {ZERO_POINT}")
        for node in _consumers(model, q[0].output[0]):
            for i, name in enumerate(node.input):
                if name == q[0].output[0]:
                    node.input[i] = nchw
        g.node.remove(q[0])
    else:
        g.initializer.extend([numpy_helper.from_array(np.array(1 / 127, np.float32), "raster_scale"),
                              numpy_helper.from_array(np.array(ZERO_POINT, np.uint8), "raster_zero_point")])
        new_nodes.append(helper.make_node("DequantizeLinear", [nchw, "raster_scale", "raster_zero_point"],
                                          [float_input], name="raster_dequantize"))
    if layout == "planes":
        g.initializer.append(numpy_helper.from_array(np.array([1, 16, 0, 0], np.int64), "raster_nchw_shape"))
        new_nodes = [helper.make_node("Transpose", [new_name], [f"{new_name}_t"], perm=[0, 3, 1, 2]),
                     helper.make_node("Reshape", [f"{new_name}_t", "raster_nchw_shape"], [nchw])] + new_nodes
        shape = [4, "height", "width", 4]
    else:
        shape = [1, 16, "height", "width"]
    for i, n in enumerate(new_nodes):
        g.node.insert(i, n)
    g.input.remove(old)
    g.input.insert(0, helper.make_tensor_value_info(new_name, TensorProto.UINT8, shape))
    # Drop stale shape annotations of the replaced float input.
    for vi in list(g.value_info):
        if vi.name == float_input and quantized:
            g.value_info.remove(vi)
    return model
