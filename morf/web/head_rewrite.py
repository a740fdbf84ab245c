"""Web-only rewrite of the renderer's fp32 head: its 1 x 1 layers as ``Conv`` nodes.

The exported head writes each 1 x 1 layer after the last int8 convolution as a ``MatMul`` on a
reshaped tensor::

    Reshape(x, [0, 0, -1]) -> MatMul(W (O, C), .) -> Add(., b (1, O, 1)) -> Reshape(., (N, O, H, W) of x)

onnxruntime runs that as four kernels, each a pass over the tensor (the two reshapes copy-free,
the bias ``Add`` a full pass of its own), plus the shape arithmetic that rebuilds (N, O, H, W)
from ``Shape(x)``. A 1 x 1 ``Conv(x, W[..., None, None], b)`` is the same function in one kernel
(onnxruntime's MLAS GEMM with the bias added in its output loop). The products and sums are the
same per output value, so the outputs agree to float rounding (the GEMM may sum in another order).

The rewrite matches the pattern structurally (the shapes must come from ``x`` itself, the weight
and bias must be constants) and leaves every other graph unchanged (the same bytes).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.web.graph_rewrite import _constant, _prune, coverage_by_sign


def _consumers(graph) -> dict[str, list]:
    out: dict[str, list] = {}
    for n in graph.node:
        for i in n.input:
            out.setdefault(i, []).append(n)
    return out


def _only_consumer(consumers: dict, name: str, op_type: str):
    users = consumers.get(name, [])
    return users[0] if len(users) == 1 and users[0].op_type == op_type else None


def _shape_of_dims(graph, producers: dict, name: str, x: str, out_channels: int) -> bool:
    """Whether ``name`` is Concat(N of x, out_channels, H of x, W of x), the exporter's shape of
    the 1 x 1 layer's output."""
    concat = producers.get(name)
    if concat is None or concat.op_type != "Concat" or len(concat.input) != 4:
        return False
    for i, part in enumerate(concat.input):
        if i == 1:
            c = _constant(graph, part)
            if c is None or np.ravel(c).tolist() != [out_channels]:
                return False
            continue
        unsq = producers.get(part)
        gather = producers.get(unsq.input[0]) if unsq is not None and unsq.op_type == "Unsqueeze" else None
        shape = producers.get(gather.input[0]) if gather is not None and gather.op_type == "Gather" else None
        index = _constant(graph, gather.input[1]) if shape is not None else None
        if shape is None or shape.op_type != "Shape" or shape.input[0] != x or index is None or int(index) != [0, 0, 2, 3][i]:
            return False
    return True


def _match(graph, producers: dict, consumers: dict, matmul):
    """(x, weight (O, C), bias (O,) or None, output name, nodes replaced) of one 1 x 1 layer
    written as a MatMul, or None."""
    w = _constant(graph, matmul.input[0])
    first = producers.get(matmul.input[1])
    if w is None or w.ndim != 2 or first is None or first.op_type != "Reshape":
        return None
    flat = _constant(graph, first.input[1])
    if flat is None or np.ravel(flat).tolist() != [0, 0, -1]:
        return None
    x, last, bias, add = first.input[0], _only_consumer(consumers, matmul.output[0], "Reshape"), None, None
    if last is None:
        add = _only_consumer(consumers, matmul.output[0], "Add")
        other = [i for i in (add.input if add is not None else []) if i != matmul.output[0]]
        bias = _constant(graph, other[0]) if len(other) == 1 else None
        if bias is None or bias.size != w.shape[0] or bias.shape[-1:] != (1,):
            return None
        last = _only_consumer(consumers, add.output[0], "Reshape")
    if last is None or not _shape_of_dims(graph, producers, last.input[1], x, w.shape[0]):
        return None
    nodes = [first, matmul, *([add] if add is not None else []), last]
    return x, w, None if bias is None else np.ravel(bias), last.output[0], nodes


def matmul_as_conv(model_bytes: bytes) -> bytes:
    """Rewrite every 1 x 1 layer the exporter wrote as ``Reshape -> MatMul -> (Add) -> Reshape``
    on an NCHW tensor into one ``Conv`` with a 1 x 1 kernel; returns the graph unchanged (the same
    bytes) when it has none."""
    import onnx
    from onnx import helper, numpy_helper

    model = onnx.load_from_string(model_bytes)
    g = model.graph
    producers = {o: n for n in g.node for o in n.output}
    consumers = _consumers(g)
    found = [m for n in g.node if n.op_type == "MatMul" and (m := _match(g, producers, consumers, n)) is not None]
    if not found:
        return model_bytes
    replaced = {id(n) for m in found for n in m[4]}
    convs = {}
    for x, w, b, out, nodes in found:
        name = f"{nodes[1].name or out}_as_conv"
        weight = numpy_helper.from_array(w.astype(np.float32)[:, :, None, None], f"{name}_weight")
        g.initializer.append(weight)
        inputs = [x, weight.name]
        if b is not None:
            g.initializer.append(numpy_helper.from_array(b.astype(np.float32), f"{name}_bias"))
            inputs.append(f"{name}_bias")
        convs[id(nodes[-1])] = helper.make_node("Conv", inputs, [out], name=name, kernel_shape=[1, 1])
    nodes = [convs.get(id(n), n) for n in g.node if id(n) not in replaced or id(n) in convs]
    del g.node[:]
    g.node.extend(nodes)
    _prune(g)
    return model.SerializeToString()


def _attr(node, name: str, default=None):
    from onnx import helper

    return next((helper.get_attribute_value(a) for a in node.attribute if a.name == name), default)


def _pointwise_conv(graph, node) -> bool:
    """A 1 x 1 convolution without stride, padding, dilation or groups: a linear map per pixel."""
    w = _constant(graph, node.input[1]) if node.op_type == "Conv" and len(node.input) >= 2 else None
    return (w is not None and w.shape[2:] == (1, 1) and _attr(node, "group", 1) == 1
            and all(v == 1 for v in _attr(node, "strides", [1, 1]) + _attr(node, "dilations", [1, 1]))
            and not any(_attr(node, "pads", [0])) and _attr(node, "auto_pad", b"NOTSET") in (b"NOTSET", b"VALID"))


def _spatial_linear_resize(graph, node) -> bool:
    """A bilinear ``Resize`` by constant scales that leaves N and C alone: each output pixel a
    weighted sum of input pixels whose weights sum to 1 (so a bias passes through it unchanged)."""
    scales = _constant(graph, node.input[2]) if len(node.input) >= 3 and node.input[2] else None
    return (node.op_type == "Resize" and (len(node.input) < 4 or not node.input[3]) and scales is not None
            and np.ravel(scales)[:2].tolist() == [1.0, 1.0] and _attr(node, "mode") == b"linear"
            and not _attr(node, "antialias", 0) and not _attr(node, "axes")
            and _attr(node, "coordinate_transformation_mode", b"half_pixel") != b"tf_crop_and_resize")


def resize_before_conv(model_bytes: bytes) -> bytes:
    """Rewrite ``Conv1x1(x) -> Resize(bilinear) -> Add(skip)`` into ``Resize(x) -> Conv1x1 -> Add(skip)``
    where the convolution has no fewer output channels than input channels.

    The two commute (a linear map per pixel and a linear interpolation between pixels; the bias
    passes through since the interpolation weights sum to 1), and the resize then reads no more
    channels than before. The gain is what follows: with the convolution's output feeding the
    ``Add`` (and its activation) directly, onnxruntime fuses Conv + Add + LeakyRelu into one
    ``FusedConv`` kernel, so the skip sum and the activation no longer each take a pass over the
    full-resolution tensor. The convolution does its products at the resized resolution instead.
    Returns the graph unchanged (the same bytes) when no such pattern is in it."""
    import onnx

    model = onnx.load_from_string(model_bytes)
    g = model.graph
    consumers = _consumers(g)
    producers = {o: n for n in g.node for o in n.output}
    graph_outputs = {o.name for o in g.output}
    moved = []
    for resize in g.node:
        conv = producers.get(resize.input[0]) if resize.op_type == "Resize" else None
        if conv is None or not _pointwise_conv(g, conv) or not _spatial_linear_resize(g, resize):
            continue
        w = _constant(g, conv.input[1])
        if (w.shape[0] < w.shape[1] or conv.output[0] in graph_outputs
                or len(consumers.get(conv.output[0], [])) != 1
                or _only_consumer(consumers, resize.output[0], "Add") is None):
            continue
        x, y, out = conv.input[0], conv.output[0], resize.output[0]
        resize.input[0], resize.output[0] = x, y  # the resize now reads x and writes a tensor of x's channels
        conv.input[0], conv.output[0] = y, out
        moved.append((conv, resize))
    if not moved:
        return model_bytes
    renamed = {resize.output[0] for _, resize in moved}  # now of the input's channel count: no stale shapes
    kept = [v for v in g.value_info if v.name not in renamed]
    del g.value_info[:]
    g.value_info.extend(kept)
    order = [n for n in g.node if all(n is not c for c, _ in moved)]
    for conv, resize in moved:  # each convolution right after its resize (topological order)
        order.insert(next(k for k, n in enumerate(order) if n is resize) + 1, conv)
    del g.node[:]
    g.node.extend(order)
    return model.SerializeToString()


def rewrite_head(model_bytes: bytes) -> bytes:
    """The head's rewrites for the page: its MatMul 1 x 1 layers as Conv, then the bilinear resize
    moved before the 1 x 1 layer that feeds the skip sum (see :func:`resize_before_conv`)."""
    return resize_before_conv(matmul_as_conv(model_bytes))


def web_rewrites(model_bytes: bytes) -> bytes:
    """What the web export does to the cut graph after the slice rewrite: :func:`rewrite_head`
    and the fill's coverage test (:func:`morf.web.graph_rewrite.coverage_by_sign`)."""
    return coverage_by_sign(rewrite_head(model_bytes))


# The page's renderer graph in the forms `morf bench web --compare graph:A,B` plays in turn, each
# from the graph the web export cut (and gave the slice rewrite of :mod:`morf.web.graph_rewrite`):
# as exported, the head's MatMuls as Conv, the head rewritten, and everything the web export does.
GRAPH_FORMS = {"matmul": lambda b: b, "conv": matmul_as_conv, "fused": rewrite_head, "web": web_rewrites}


def rewrite_web_renderer(avatar_folder: Path) -> None:
    """Give a web folder's ``avatar/renderer.onnx`` the rewrites of :func:`web_rewrites` in
    place, and its size and sha256 in ``avatar.json`` with it; a graph without the pattern stays."""
    import hashlib
    import json

    from morf.io.atomic import atomic_write_bytes, atomic_write_text

    path = Path(avatar_folder) / "renderer.onnx"
    raw = path.read_bytes()
    new = web_rewrites(raw)
    if new == raw:
        return
    atomic_write_bytes(path, new)
    doc_path = Path(avatar_folder) / "avatar.json"
    doc = json.loads(doc_path.read_text())
    doc["files"][path.name] = {"bytes": len(new), "sha256": hashlib.sha256(new).hexdigest()}
    atomic_write_text(doc_path, json.dumps(doc, separators=(",", ":")))  # as morf.web.web_avatar writes it
