"""Small ONNX graph edits used by the exporter (pure onnx, no torch).

* :func:`fold_input_scale`: a per-channel ``Mul`` right after the input is folded into the
  weights of the convolutions that read it (directly or through a channel ``Concat``), so the
  dequantisation of the uint8 neural rasterization costs nothing at run time and zero padding
  stays exact (padding happens after the scale in both cases).
* :func:`uint8_input`: the graph takes the GL read-back bytes directly, in one of two layouts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from morf.raster.neural_raster import COVERAGE_CHANNEL, LAYOUTS
from morf.raster.texture_quant import ZERO_POINT


def _initializers(model: onnx.ModelProto) -> dict[str, onnx.TensorProto]:
    return {t.name: t for t in model.graph.initializer}


def _consumers(model: onnx.ModelProto, name: str) -> list[onnx.NodeProto]:
    return [n for n in model.graph.node if name in n.input]


def const_value(model: onnx.ModelProto, name: str) -> np.ndarray | None:
    """The value of tensor ``name`` when the graph fixes it (an initializer or a Constant node), else
    None: what a graph pass may fold, and what the native tail reads its constants from."""
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
    if len(muls) != 1:  # other consumers (e.g. the texture-colour fill) keep reading the raw input
        return False
    mul = muls[0]
    other = mul.input[1] if mul.input[0] == input_name else mul.input[0]
    s = const_value(model, other)
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


def downstream_nodes(model: onnx.ModelProto, name: str) -> list[str]:
    """Names of the nodes that read ``name`` directly or through other nodes."""
    found, frontier = [], {name}
    for node in model.graph.node:  # ONNX graphs are stored in topological order
        if frontier.intersection(node.input):
            found.append(node.name)
            frontier.update(node.output)
    return found


def uint8_input(model: onnx.ModelProto, float_input: str, layout: str, new_name: str = "raster",
                quantized: bool = False) -> onnx.ModelProto:
    """Make the graph read uint8 bytes instead of the float input ``x = (q - 128) / 127``.

    ``quantized=False`` (fp32 graph): a ``DequantizeLinear(1/127, 128)`` is inserted.
    ``quantized=True`` (QDQ graph whose input ``QuantizeLinear`` already uses exactly 1/127 and
    128): that ``QuantizeLinear`` is removed, its consumers read the bytes directly.
    ``layout`` (see :data:`LAYOUTS`): the graph rearranges "nhwc" and "planes" inputs itself
    (uint8 transposes, 4x cheaper than on floats, and free for "nhwc" in onnxruntime).
    """
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}")
    g = model.graph
    old = next(i for i in g.input if i.name == float_input)
    nchw = new_name if layout == "nchw" else f"{new_name}_nchw"
    new_nodes = []
    if quantized:
        q = [n for n in _consumers(model, float_input) if n.op_type == "QuantizeLinear"]
        if len(q) != 1 or len(_consumers(model, float_input)) != 1:
            raise ValueError("expected one QuantizeLinear on the renderer input")
        sc, zp = const_value(model, q[0].input[1]), const_value(model, q[0].input[2])
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
    elif layout == "nhwc":
        new_nodes = [helper.make_node("Transpose", [new_name], [nchw], perm=[0, 3, 1, 2])] + new_nodes
        shape = [1, "height", "width", 16]
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


COMPOSITE_PREFIX = "composite_"


def append_composite(model: onnx.ModelProto, rgba: str = "rgba", background: str = "background",
                     image: str = "image") -> onnx.ModelProto:
    """Add the compositing to the graph, in place: a second output ``image`` (1, H, W, 3) uint8 =
    ``round(clip(255 * rgb + (1 - mask) * background, 0, 255))`` (ties to even) from the
    premultiplied ``rgba`` (1, 4, H, W) output and a new float32 input ``background``
    (1, 3, H, W) in 0-255, or (1, 3, 1, 1) for a plain colour (broadcast). The input is required
    even when only ``rgba`` is fetched (feed zeros); an optional input (an initializer of the same
    name) would do, but onnxruntime warns about those on every session it opens.

    The compositing runs on onnxruntime's threads in channel planes (broadcasting the mask over
    channel planes is a fast path; channels-last it is not), then a uint8 Transpose (0.2 ms at
    640x640) interleaves the image. The no-op Reshape before that Transpose fences it: without
    it onnxruntime's transpose optimizer moves it up through the float ops, which then broadcast
    along the last axis and cost 7 ms more (measured at 640x640, 2 threads).
    """
    g = model.graph
    if any(o.name == image for o in g.output):
        return model
    g.initializer.extend([numpy_helper.from_array(np.array(1.0, np.float32), "composite_one"),
                          numpy_helper.from_array(np.array(1.0 / 255.0, np.float32), "composite_unit"),
                          numpy_helper.from_array(np.array(0, np.uint8), "composite_zero"),
                          numpy_helper.from_array(np.array([1, 3, 0, 0], np.int64), "composite_shape")])
    # The premultiplied RGB and the mask as the graph makes them, before they are concatenated into
    # ``rgba`` (splitting it again copied four full-resolution planes).
    concat = producer(model, rgba)
    if concat is not None and concat.op_type == "Concat" and len(concat.input) == 2 \
            and attr(concat, "axis") in (1, -3):
        nodes, (rgb, mask) = [], concat.input
    else:
        g.initializer.append(numpy_helper.from_array(np.array([3, 1], np.int64), "composite_split"))
        rgb, mask = "composite_rgb", "composite_mask"
        nodes = [helper.make_node("Split", [rgba, "composite_split"], [rgb, mask], axis=1)]
    # In [0, 1] throughout; QuantizeLinear with scale 1/255 multiplies by 255, rounds and
    # saturates to uint8 in one op (a Clip, an Add of 0.5 and a Cast before; it rounds a tie to
    # even where they rounded it up).
    nodes += [
        helper.make_node("Sub", ["composite_one", mask], ["composite_inv"]),
        helper.make_node("Mul", [background, "composite_unit"], ["composite_bg_unit"]),
        helper.make_node("Mul", ["composite_inv", "composite_bg_unit"], ["composite_bg"]),
        helper.make_node("Add", [rgb, "composite_bg"], ["composite_sum"]),
        helper.make_node("QuantizeLinear", ["composite_sum", "composite_unit", "composite_zero"], ["composite_planes"]),
        helper.make_node("Reshape", ["composite_planes", "composite_shape"], ["composite_fence"]),
        helper.make_node("Transpose", ["composite_fence"], [image], perm=[0, 2, 3, 1]),
    ]
    for i, node in enumerate(nodes):
        node.name = f"{COMPOSITE_PREFIX}{i}_{node.op_type}"  # profiles tell the compositing's share by name
    g.node.extend(nodes)
    g.input.append(helper.make_tensor_value_info(background, TensorProto.FLOAT, [1, 3, "bg_height", "bg_width"]))
    g.output.append(helper.make_tensor_value_info(image, TensorProto.UINT8, [1, "height", "width", 3]))
    return model


def producer(model: onnx.ModelProto, name: str) -> onnx.NodeProto | None:
    """The node that writes tensor ``name``, or None for a graph input or an initializer."""
    return next((n for n in model.graph.node if name in n.output), None)


def attr(node: onnx.NodeProto, name: str):
    """The value of ``node``'s attribute ``name`` (int, float, bytes, list...), or None when unset."""
    return next((helper.get_attribute_value(a) for a in node.attribute if a.name == name), None)


def _remove_if_unused(model: onnx.ModelProto, node: onnx.NodeProto | None) -> None:
    outputs = {o.name for o in model.graph.output}
    if node is not None and not any(_consumers(model, o) or o in outputs for o in node.output):
        model.graph.node.remove(node)


def _sort_nodes(model: onnx.ModelProto) -> None:
    """Put the graph's nodes back in topological order after an edit inserted some out of it,
    keeping the present order wherever it is already valid."""
    g = model.graph
    ready = {i.name for i in g.input} | {t.name for t in g.initializer} | {""}
    pending, ordered = list(g.node), []
    while pending:
        for k, n in enumerate(pending):
            if all(i in ready for i in n.input):
                ordered.append(pending.pop(k))
                ready.update(n.output)
                break
        else:
            raise ValueError(f"the graph has a cycle or a missing input at {pending[0].name}")
    del g.node[:]
    g.node.extend(ordered)


@dataclass(frozen=True)
class _CoverageOp:
    """The torch graph's coverage ``sum(|x|, channels) > 0`` on the dequantised input, as found in
    the graph: ``greater`` (the comparison with 0), ``reduce`` (the ReduceSum over channels),
    ``abs``, ``passed`` (no-op float Casts and Identities between the input and the Abs, nearest
    the Abs first) and ``dequantize`` (the raster's ``DequantizeLinear``)."""

    greater: onnx.NodeProto
    reduce: onnx.NodeProto
    abs: onnx.NodeProto
    passed: tuple[onnx.NodeProto, ...]
    dequantize: onnx.NodeProto


def _find_coverage(model: onnx.ModelProto, greater: onnx.NodeProto, nchw: str) -> _CoverageOp | None:
    """The coverage ending at ``greater`` when it reads the uint8 input ``nchw`` through a
    ``DequantizeLinear`` with the texture's zero point; None for any other comparison."""
    red = producer(model, greater.input[0])
    ab = producer(model, red.input[0]) if red is not None and red.op_type == "ReduceSum" else None
    dq = producer(model, ab.input[0]) if ab is not None and ab.op_type == "Abs" else None
    passed = []  # a no-op float Cast (torch's ``x.float()``) between the input and the Abs
    while dq is not None and (dq.op_type == "Identity" or (dq.op_type == "Cast" and attr(dq, "to") == TensorProto.FLOAT)):
        passed.append(dq)
        dq = producer(model, dq.input[0])
    zero = const_value(model, greater.input[1])
    if dq is None or dq.op_type != "DequantizeLinear" or dq.input[0] != nchw or zero is None or float(zero) != 0.0:
        return None
    zp = const_value(model, dq.input[2])
    if zp is None or zp.dtype != np.uint8 or int(zp) != ZERO_POINT:
        return None
    return _CoverageOp(greater, red, ab, tuple(passed), dq)


def _colour_from_bytes(model: onnx.ModelProto, op: _CoverageOp, nchw: str) -> tuple[list[str], tuple[str, int]]:
    """Each colour ``x[:, :k]`` sliced from the dequantised input becomes the same slice of the
    bytes, then dequantised, in place. Returns what was rewritten and where the coverage byte is
    read from: a (1, C, H, W) uint8 tensor and the coverage byte's channel in it (a sliced
    colour's contiguous planes when they hold that channel, else the whole input)."""
    g, dq, done = model.graph, op.dequantize, []
    bytes_from = (nchw, COVERAGE_CHANNEL)
    readers = [n for t in (dq,) + op.passed for n in _consumers(model, t.output[0])]
    for sl in [n for n in readers if n.op_type == "Slice"]:
        starts, ends = const_value(model, sl.input[1]), const_value(model, sl.input[2])
        ax = const_value(model, sl.input[3]) if len(sl.input) > 3 and sl.input[3] else np.array([0])
        steps = const_value(model, sl.input[4]) if len(sl.input) > 4 and sl.input[4] else np.array([1])
        if any(v is None for v in (starts, ends, ax, steps)) or list(ax.reshape(-1)) != [1] \
                or int(starts.reshape(-1)[0]) != 0 or int(steps.reshape(-1)[0]) != 1:
            continue
        # from the channel-planar bytes (for "nhwc" a uint8 transpose of 0.5 ms at 640x640):
        # slicing 3 of a pixel's 16 interleaved bytes took 1.8 ms, three contiguous planes 0.7
        q = f"{sl.name}_uint8"
        nodes = [helper.make_node("Slice", [nchw] + list(sl.input[1:]), [f"{q}_bytes"], name=q),
                 helper.make_node("DequantizeLinear", [f"{q}_bytes", dq.input[1], dq.input[2]], [sl.output[0]],
                                  name=f"{q}_dq")]
        _replace_node(model, sl, nodes)
        done.append(f"colour {sl.name}")
        if int(ends.reshape(-1)[0]) > COVERAGE_CHANNEL:
            bytes_from = (f"{q}_bytes", COVERAGE_CHANNEL)
    return done, bytes_from


def _coverage_from_bytes(model: onnx.ModelProto, greater: onnx.NodeProto, src: str, channel: int) -> None:
    """``greater``'s output computed as ``|byte - zp| > 0`` on the one byte plane ``channel`` of
    ``src``, in place (onnxruntime's uint8 comparisons with a broadcast scalar took 5 ms each at
    640x640; these float ops on one plane take tenths)."""
    p = f"{greater.name}_uint8"
    model.graph.initializer.extend([numpy_helper.from_array(np.array(ZERO_POINT, np.float32), f"{p}_zp"),
                                    numpy_helper.from_array(np.array(0.0, np.float32), f"{p}_zero"),
                                    numpy_helper.from_array(np.array([channel], np.int64), f"{p}_start"),
                                    numpy_helper.from_array(np.array([channel + 1], np.int64), f"{p}_end"),
                                    numpy_helper.from_array(np.array([1], np.int64), f"{p}_axis")])
    nodes = [helper.make_node("Slice", [src, f"{p}_start", f"{p}_end", f"{p}_axis"], [f"{p}_byte"], name=f"{p}_byte"),
             helper.make_node("Cast", [f"{p}_byte"], [f"{p}_value"], to=TensorProto.FLOAT, name=f"{p}_value"),
             helper.make_node("Sub", [f"{p}_value", f"{p}_zp"], [f"{p}_off"], name=f"{p}_off"),
             helper.make_node("Abs", [f"{p}_off"], [f"{p}_offabs"], name=f"{p}_offabs"),
             helper.make_node("Greater", [f"{p}_offabs", f"{p}_zero"], [greater.output[0]], name=f"{p}_covered")]
    _replace_node(model, greater, nodes)


def _replace_node(model: onnx.ModelProto, old: onnx.NodeProto, nodes: list[onnx.NodeProto]) -> None:
    """``nodes`` where ``old`` stood in the graph's node list, ``old`` removed."""
    g = model.graph
    at = list(g.node).index(old)
    g.node.remove(old)
    for i, n in enumerate(nodes):
        g.node.insert(at + i, n)


def _drop_unused_constants(model: onnx.ModelProto) -> None:
    """Remove the Constant nodes and initializers nothing reads (the replaced nodes' constants:
    onnxruntime warns about unused ones)."""
    g = model.graph
    used = {i for n in g.node for i in n.input}
    for n in [n for n in g.node if n.op_type == "Constant" and n.output[0] not in used]:
        g.node.remove(n)
    for t in [t for t in g.initializer if t.name not in used]:
        g.initializer.remove(t)


def uint8_colour_head(model: onnx.ModelProto, layout: str, raster: str = "raster") -> list[str]:
    """Feed the texture-colour head (``TextureColour`` of an ``rgb_skip`` renderer) from the uint8
    bytes, in place, after :func:`uint8_input`. Returns what was rewritten ([] when the graph has
    no colour head).

    * Colour: ``x[:, :3]`` sliced after dequantising all 16 channels becomes the 3 channels
      sliced from the bytes, then dequantised.
    * Coverage: the torch graph computes ``sum(|x|, channels) > 0`` on the dequantised float
      input, 16 float planes at full resolution (10 ms of a 76 ms frame at 640x640 on 2 cores).
      The rasterizer marks its coverage in the bytes instead: on the body channel
      :data:`~morf.raster.neural_raster.COVERAGE_CHANNEL`'s byte is never the zero point, off it
      every byte is (:mod:`morf.raster.neural_raster`). So the mask is ``byte0 != zp`` on that
      one plane, taken from the colour's byte planes (contiguous; 1.6 ms a frame less than a
      max / min over the 16 bytes of each pixel on 2 cores).
    """
    nchw = raster if layout == "nchw" else f"{raster}_nchw"
    done = []
    for greater in [n for n in model.graph.node if n.op_type == "Greater"]:
        op = _find_coverage(model, greater, nchw)
        if op is None:
            continue
        # the colour first: the coverage plane is read from its bytes
        colour, (src, channel) = _colour_from_bytes(model, op, nchw)
        done += colour
        _coverage_from_bytes(model, greater, src, channel)
        for node in [op.reduce, op.abs]:
            _remove_if_unused(model, node)
        done.append(f"coverage {greater.name}")
        for node in reversed(op.passed):
            _remove_if_unused(model, node)
        _remove_if_unused(model, op.dequantize)
    if done:
        _sort_nodes(model)
    _drop_unused_constants(model)
    return done


OPAQUE_PREFIX = "opaque_"
OPAQUE_MARGIN_PX = 4  # how far inside the body mesh's outline the mask is held at 1


def opaque_body(model: onnx.ModelProto, margin: int = OPAQUE_MARGIN_PX) -> bool:
    """Hold the mask at 1 inside the body mesh, in place: ``mask = max(sigmoid(logit), inside)``
    where ``inside`` is the rasterizer's coverage shrunk by ``margin`` pixels (a separable
    MaxPool of the uncovered pixels). The fitted body is opaque; the renderer's mask shapes the
    outline, hair and loose cloth, but a hole well inside the body is never right, and trained
    avatars had a few (a light speck at the throat, dots at a shoulder) where the texture was rarely
    seen. Playback only: the torch renderer and ``morf eval`` do not do it. Needs the uint8
    coverage of :func:`uint8_colour_head`; returns False (graph unchanged) without it.
    """
    g = model.graph
    marks = [n for n in g.node if n.op_type == "Greater" and n.name.endswith("_uint8_covered")]
    casts = [c for u in marks for c in _consumers(model, u.output[0])
             if c.op_type == "Cast" and attr(c, "to") == TensorProto.FLOAT]
    sigmoids = [n for n in g.node if n.op_type == "Sigmoid"]
    if not casts or not sigmoids:
        return False
    cov, sig = casts[0], sigmoids[-1]
    readers = _consumers(model, sig.output[0])
    k, p = 2 * margin + 1, OPAQUE_PREFIX
    g.initializer.append(numpy_helper.from_array(np.array(1.0, np.float32), f"{p}one"))
    nodes = [helper.make_node("Sub", [f"{p}one", cov.output[0]], [f"{p}off"], name=f"{p}off"),
             helper.make_node("MaxPool", [f"{p}off"], [f"{p}grow_x"], kernel_shape=[1, k], pads=[0, margin, 0, margin],
                              name=f"{p}grow_x"),
             helper.make_node("MaxPool", [f"{p}grow_x"], [f"{p}grow"], kernel_shape=[k, 1], pads=[margin, 0, margin, 0],
                              name=f"{p}grow"),
             helper.make_node("Sub", [f"{p}one", f"{p}grow"], [f"{p}inside"], name=f"{p}inside"),
             helper.make_node("Max", [sig.output[0], f"{p}inside"], [f"{p}mask"], name=f"{p}mask")]
    at = max(list(g.node).index(sig), list(g.node).index(cov)) + 1
    for i, n in enumerate(nodes):
        g.node.insert(at + i, n)
    for r in readers:
        for j, name in enumerate(r.input):
            if name == sig.output[0]:
                r.input[j] = f"{p}mask"
    return True
