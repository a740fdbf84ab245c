"""Web-only rewrites of the renderer graph: the same function, in a form onnxruntime-web's WASM
kernels run with less memory traffic. Each rewrite here leaves every output bit-identical; the web
export applies them after cutting the graph (the head's, :mod:`morf.web.head_rewrite`, to float rounding).

- Channel slices before the layout transpose: the exported graph turns the (1, H, W, 16) raster
  into NCHW once (a full-resolution 16-channel uint8 transpose) and then slices the colour channels
  off it. The convolutions read the raster channels-last anyway (onnxruntime's int8 kernels are
  NHWC, so its transpose optimizer cancels their share of the transpose), and with the slice taken
  from the NHWC raster first only those 3 channels are transposed: the whole 16-channel transpose
  disappears from the graph onnxruntime runs.
- The colour fill's coverage test as ``Gather -> DequantizeLinear -> Abs -> Sign`` instead of a
  uint8 ``Slice`` and element-wise ``Cast``s (:func:`coverage_by_sign`).
"""

from __future__ import annotations

import numpy as np


def _constant(graph, name: str):
    """The value of initializer or Constant node output ``name``, or None."""
    from onnx import numpy_helper

    for t in graph.initializer:
        if t.name == name:
            return numpy_helper.to_array(t)
    for n in graph.node:
        if n.op_type == "Constant" and n.output[0] == name:
            return numpy_helper.to_array(n.attribute[0].t)
    return None


def _prune(graph) -> None:
    """Drop nodes whose outputs nothing reads (the shape arithmetic of replaced layers) and
    initializers no node reads."""
    outputs = {o.name for o in graph.output}
    while True:
        read = {i for n in graph.node for i in n.input} | outputs
        dead = [n for n in graph.node if not any(o in read for o in n.output)]
        if not dead:
            break
        for n in dead:
            graph.node.remove(n)
    read = {i for n in graph.node for i in n.input}
    keep = [t for t in graph.initializer if t.name in read]
    del graph.initializer[:]
    graph.initializer.extend(keep)


def _perm(node) -> list[int] | None:
    return next((list(a.ints) for a in node.attribute if a.name == "perm"), None)


def slice_before_transpose(model_bytes: bytes) -> bytes:
    """Rewrite ``Transpose(raster, NHWC->NCHW) -> Slice(channels)`` into
    ``Slice(raster, channels last) -> Transpose`` for every channel slice of a graph input's
    transpose; returns the graph unchanged (the same bytes) when it has no such pattern."""
    import onnx
    from onnx import helper, numpy_helper

    model = onnx.load_from_string(model_bytes)
    g = model.graph
    inputs = {i.name for i in g.input}
    transposes = {n.output[0]: n for n in g.node if n.op_type == "Transpose" and n.input[0] in inputs
                  and _perm(n) == [0, 3, 1, 2]}
    changed, nodes = False, []
    for n in g.node:
        t = transposes.get(n.input[0]) if n.op_type == "Slice" and len(n.input) >= 4 else None
        axes = _constant(g, n.input[3]) if t is not None else None
        if axes is None or list(np.ravel(axes)) not in ([1], [-3]):
            nodes.append(n)
            continue
        last = f"{n.name}_channels_last"
        axis = numpy_helper.from_array(np.array([3], np.int64), f"{last}_axis")
        g.initializer.append(axis)
        inputs_ = [t.input[0], n.input[1], n.input[2], axis.name, *n.input[4:]]
        nodes.append(helper.make_node("Slice", inputs_, [last], name=last))
        nodes.append(helper.make_node("Transpose", [last], list(n.output), name=f"{n.name}_to_nchw", perm=[0, 3, 1, 2]))
        changed = True
    if not changed:
        return model_bytes
    del g.node[:]
    g.node.extend(nodes)
    return model.SerializeToString()


def _dtype_from_input(graph, producers: dict, name: str) -> int | None:
    """The element type of ``name`` where it is a graph input passed through data-movement ops only."""
    inputs = {i.name: i.type.tensor_type.elem_type for i in graph.input}
    while name not in inputs:
        n = producers.get(name)
        if n is None or n.op_type not in ("Slice", "Transpose", "Gather", "Reshape"):
            return None
        name = n.input[0]
    return inputs[name]


def _scalar(graph, name: str):
    v = _constant(graph, name)
    return None if v is None or v.size != 1 else float(np.ravel(v)[0])


def _coverage_chain(graph, producers: dict, consumers: dict, cast_out):
    """The exporter's coverage test ending in ``cast_out`` (a Cast to float):
    Slice(bytes, channel c) -> Cast(float) -> Sub(zero point) -> Abs -> Greater(0) -> Cast(float).
    Returns (bytes, c, zero point, nodes) or None."""
    chain, name = [cast_out], cast_out.input[0]
    for op in ("Greater", "Abs", "Sub", "Cast", "Slice"):
        n = producers.get(name)
        if n is None or n.op_type != op or len(consumers.get(n.output[0], [])) != 1:
            return None
        chain.append(n)
        name = n.input[0]
    _, greater, _, sub, _, sl = chain
    zero, zp = _scalar(graph, greater.input[1]), _scalar(graph, sub.input[1])
    parts = [_constant(graph, i) if i else None for i in sl.input[1:]]
    if zero != 0.0 or zp is None or zp != int(zp) or not 0 <= zp <= 255 or len(parts) < 3 or any(p is None for p in parts):
        return None
    start, end, axes = (int(np.ravel(p)[0]) if np.size(p) == 1 else None for p in parts[:3])
    step = int(np.ravel(parts[3])[0]) if len(parts) > 3 and np.size(parts[3]) == 1 else 1
    if None in (start, end, axes) or axes not in (1, -3) or step != 1 or end != start + 1 or start < 0:
        return None
    from onnx import TensorProto

    if _dtype_from_input(graph, producers, sl.input[0]) != TensorProto.UINT8:
        return None
    return sl.input[0], start, int(zp), chain


def coverage_by_sign(model_bytes: bytes) -> bytes:
    """Rewrite the colour fill's coverage test (the raster's coverage byte differs from the zero
    point), written as ``Slice -> Cast -> Sub -> Abs -> Greater -> Cast`` over the full-resolution
    channel, into ``Gather -> DequantizeLinear(scale 1) -> Abs -> Sign``: the same 0.0 / 1.0 per
    pixel (``b - zp`` is exact in float32 for bytes, and ``Sign(|b - zp|)`` is 1 exactly where it is
    not 0). In onnxruntime-web the uint8 ``Slice`` and the ``Cast`` were the slow part
    (element by element); ``Gather`` of one NCHW channel is one block copy, and the
    dequantization is MLAS's vector loop. Returns the graph unchanged (the same bytes) when no such
    chain is in it."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    model = onnx.load_from_string(model_bytes)
    g = model.graph
    producers = {o: n for n in g.node for o in n.output}
    consumers: dict[str, list] = {}
    for n in g.node:
        for i in n.input:
            consumers.setdefault(i, []).append(n)
    found = [m for n in g.node if n.op_type == "Cast" and next((a.i for a in n.attribute if a.name == "to"), None) == TensorProto.FLOAT
             and (m := _coverage_chain(g, producers, consumers, n)) is not None]
    if not found:
        return model_bytes
    drop, new = set(), {}
    for k, (source, channel, zp, chain) in enumerate(found):
        tag = f"coverage_{k}"
        g.initializer.extend([numpy_helper.from_array(np.array([channel], np.int64), f"{tag}_channel"),
                              numpy_helper.from_array(np.array(1.0, np.float32), f"{tag}_one"),
                              numpy_helper.from_array(np.array(zp, np.uint8), f"{tag}_zero_point")])
        new[id(chain[0])] = [
            helper.make_node("Gather", [source, f"{tag}_channel"], [f"{tag}_byte"], name=f"{tag}_byte", axis=1),
            helper.make_node("DequantizeLinear", [f"{tag}_byte", f"{tag}_one", f"{tag}_zero_point"], [f"{tag}_offset"],
                             name=f"{tag}_offset"),
            helper.make_node("Abs", [f"{tag}_offset"], [f"{tag}_distance"], name=f"{tag}_distance"),
            helper.make_node("Sign", [f"{tag}_distance"], list(chain[0].output), name=f"{tag}_covered")]
        drop |= {id(n) for n in chain}
    nodes = []
    for n in g.node:  # each chain's replacement where its last node was: after the bytes it reads
        nodes.extend(new.get(id(n), [] if id(n) in drop else [n]))
    del g.node[:]
    g.node.extend(nodes)
    _prune(g)
    return model.SerializeToString()
