"""Web-only rewrites of the renderer graph: the same function, in a form onnxruntime-web's WASM
kernels run with less memory traffic. Each rewrite leaves every output bit-identical (they move
data-movement ops only); the web export applies them after cutting the graph.

- Channel slices before the layout transpose: the exported graph turns the (1, H, W, 16) raster
  into NCHW once (a full-resolution 16-channel uint8 transpose) and then slices the colour channels
  off it. The convolutions read the raster channels-last anyway (onnxruntime's int8 kernels are
  NHWC, so its transpose optimizer cancels their share of the transpose), and with the slice taken
  from the NHWC raster first only those 3 channels are transposed: the whole 16-channel transpose
  disappears from the graph onnxruntime runs.
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
