"""Find the renderer graph's full-resolution tail for the player's compiled pass
(:mod:`morf.export.compiled_tail`), and check that pass against the whole graph.

The tail is recognised node by node as the exporter writes it (``_Wrapper`` in
:mod:`morf.export.onnx_renderer`, then :func:`~morf.export.onnx_graph.uint8_colour_head`,
:func:`~morf.export.onnx_graph.opaque_body` and :func:`~morf.export.onnx_graph.append_composite`);
a graph that differs anywhere (a full-resolution head, no colour skip, another layout) gets no
spec and plays through the whole graph.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Sequence

import numpy as np
import onnx

from morf.export.onnx_graph import COMPOSITE_PREFIX, OPAQUE_PREFIX, _attr, _const_value, _producer
from morf.machine.compiled import numba_available
from morf.export.compiled_tail import HeadStage, TailShader, TailSpec

MAX_LEVELS = 2  # the most a pixel channel may differ from the whole graph's (rounding)
MAX_SHARE = 1e-3  # the share of pixel channels allowed to differ at all


def _node(model, name: str, op: str):
    n = _producer(model, name)
    return n if n is not None and n.op_type == op else None


def _other(node, name: str) -> str | None:
    """The input of a two-input node that is not ``name``."""
    ins = list(node.input)
    if len(ins) != 2 or name not in ins:
        return None
    return ins[1] if ins[0] == name else ins[0]


def _uncast(model, name: str) -> str:
    """``name``, or what a chain of no-op float Casts before it reads (torch's ``.to(dtype)``)."""
    n = _producer(model, name)
    while n is not None and n.op_type == "Cast" and _attr(n, "to") == onnx.TensorProto.FLOAT:
        name = n.input[0]
        n = _producer(model, name)
    return name


def _scalar(model, name: str) -> float | None:
    v = _const_value(model, name)
    return None if v is None or v.size != 1 else float(v.reshape(-1)[0])


def _resized(model, name: str, sizes_ok: bool = False) -> str | None:
    """The input of the 2x bilinear half-pixel Resize that makes ``name``, or None. ``sizes_ok``:
    also a Resize to computed ``sizes`` (the fill's last pull step resizes to the frame's size:
    twice its input's side on the even sides the player renders; the pass checks the shapes each
    frame)."""
    rs = _node(model, name, "Resize")
    if rs is None or _attr(rs, "mode") not in (b"linear", "linear") \
            or _attr(rs, "coordinate_transformation_mode") not in (b"half_pixel", "half_pixel", b"pytorch_half_pixel", "pytorch_half_pixel"):
        return None
    scales = _const_value(model, rs.input[2]) if len(rs.input) > 2 and rs.input[2] else None
    if scales is not None and list(scales.reshape(-1)) == [1.0, 1.0, 2.0, 2.0]:
        return rs.input[0]
    if sizes_ok and scales is None and len(rs.input) > 3 and rs.input[3]:
        return rs.input[0]
    return None


def _upsampled(model, name: str) -> str | None:
    """The input of the 2x Resize that makes ``name`` through a Split of 3 + 1 channels."""
    split = _producer(model, name)
    if split is None or split.op_type != "Split" or list(split.input[:1]) == [] or _attr(split, "axis") not in (1, -3):
        return None
    sizes = _const_value(model, split.input[1]) if len(split.input) > 1 else None
    if sizes is None or list(sizes.reshape(-1)) != [3, 1]:
        return None
    return _resized(model, split.input[0], sizes_ok=True)


def _head_stage(model, head: str) -> HeadStage | None:
    """The int8 graph's half-resolution head before ``head``: ``Reshape(Add(MatMul(weight,
    Reshape(LeakyRelu(Add(Resize2x(low), DequantizeLinear(skip))))), bias))``; None otherwise
    (the fp32 graph's last 1x1 convolution has weights computed in the graph, so it stays there)."""
    out = _node(model, head, "Reshape")
    add = _node(model, out.input[0], "Add") if out is not None else None
    mm_out = next((i for i in add.input if _node(model, i, "MatMul") is not None), None) if add is not None else None
    if mm_out is None:
        return None
    mm, bias = _producer(model, mm_out), _const_value(model, _other(add, mm_out))
    weight = _const_value(model, mm.input[0])
    flat = _node(model, mm.input[1], "Reshape")
    act = _node(model, flat.input[0], "LeakyRelu") if flat is not None else None
    total = _node(model, act.input[0], "Add") if act is not None else None
    if weight is None or bias is None or weight.ndim != 2 or bias.size != weight.shape[0] or total is None:
        return None
    low = next((_resized(model, i) for i in total.input if _resized(model, i) is not None), None)
    if low is None:
        return None
    skip = next(i for i in total.input if _resized(model, i) is None)
    scale, zp = 1.0, 0
    dq = _node(model, skip, "DequantizeLinear")
    if dq is not None:
        scale, zero = _scalar(model, dq.input[1]), _const_value(model, dq.input[2])
        if scale is None or zero is None or zero.size != 1:
            return None
        skip, zp = dq.input[0], int(zero.reshape(-1)[0])
    alpha = _attr(act, "alpha")
    return HeadStage(low=low, skip=skip, skip_scale=float(scale), skip_zero_point=zp,
                     alpha=float(0.01 if alpha is None else alpha),
                     weight=tuple(tuple(float(v) for v in row) for row in weight),
                     bias=tuple(float(v) for v in bias.reshape(-1)))


def tail_spec(model: onnx.ModelProto, layout: str) -> TailSpec | None:
    """The tail of an exported renderer graph (see the module docstring), or None."""
    if layout != "nhwc":
        return None
    inv = next((n for n in model.graph.node if n.name == f"{COMPOSITE_PREFIX}0_Sub"), None)
    add = next((n for n in model.graph.node if n.name == f"{COMPOSITE_PREFIX}3_Add"), None)
    if inv is None or add is None or _scalar(model, inv.input[0]) != 1.0:
        return None
    mask = inv.input[1]
    margin, sig_out = 0, mask
    top = _producer(model, mask)
    if top is not None and top.op_type == "Max" and top.name.startswith(OPAQUE_PREFIX):
        sig_out = top.input[0]
        pool = next((n for n in model.graph.node if n.name == f"{OPAQUE_PREFIX}grow_x"), None)
        kernel = _attr(pool, "kernel_shape") if pool is not None else None
        if not kernel or kernel[-1] % 2 != 1:
            return None
        margin = (kernel[-1] - 1) // 2
    sig = _node(model, sig_out, "Sigmoid")
    if sig is None:
        return None
    k, c, pre = 1.0, 0.0, sig.input[0]
    shift = _node(model, pre, "Add")
    if shift is not None:
        scaled = next((i for i in shift.input if _producer(model, i) is not None and _producer(model, i).op_type == "Mul"), None)
        mul = _producer(model, scaled) if scaled is not None else None
        c = _scalar(model, _other(shift, scaled)) if scaled is not None else None
        if mul is None or c is None:
            return None
        pre = next((i for i in mul.input if _scalar(model, i) is None), None)
        k = _scalar(model, _other(mul, pre)) if pre is not None else None
        if k is None:
            return None
    head = _upsampled(model, pre)
    head_split = _producer(model, pre)
    if head is None or list(head_split.output).index(pre) != 1:
        return None
    # the premultiplied RGB: (residual + colour) * mask
    prem = _node(model, add.input[0], "Mul")
    if prem is None or _other(prem, mask) is None:
        return None
    rgb = _node(model, _other(prem, mask), "Add")
    residual = head_split.output[0]
    if rgb is None or _other(rgb, residual) is None:
        return None
    colour = _node(model, _other(rgb, residual), "Add")
    if colour is None:
        return None
    tex_mul = fill_mul = None
    for i in colour.input:
        n = _producer(model, _uncast(model, i))
        if n is not None and n.op_type == "Mul" and any(_node(model, j, "DequantizeLinear") is not None for j in n.input):
            tex_mul = n
        elif n is not None and n.op_type == "Mul":
            fill_mul = n
    if tex_mul is None or fill_mul is None:
        return None
    dq_out = next(j for j in tex_mul.input if _node(model, j, "DequantizeLinear") is not None)
    dq = _producer(model, dq_out)
    scale = _const_value(model, _other(tex_mul, dq_out))
    dq_scale, zp = _scalar(model, dq.input[1]), _const_value(model, dq.input[2])
    sl = _node(model, dq.input[0], "Slice")
    if scale is None or scale.size != 3 or dq_scale is None or zp is None or sl is None:
        return None
    starts, ends, axes = (_const_value(model, sl.input[i]) for i in (1, 2, 3))
    if any(v is None for v in (starts, ends, axes)) or (int(starts[0]), int(ends[0]), int(axes[0])) != (0, 3, 1):
        return None
    # fill term: up(FILL)[:3] * ((1 - covered) / max(up(FILL)[3], weight_min))
    div = next((_node(model, i, "Div") for i in fill_mul.input if _node(model, i, "Div") is not None), None)
    if div is None:
        return None
    fill_rgb = _other(fill_mul, div.output[0])
    fill = _upsampled(model, fill_rgb)
    sub, clip = _node(model, div.input[0], "Sub"), _node(model, div.input[1], "Clip")
    if fill is None or sub is None or clip is None or _scalar(model, sub.input[0]) != 1.0:
        return None
    fill_split = _producer(model, fill_rgb)
    if list(fill_split.output).index(fill_rgb) != 0 or clip.input[0] != fill_split.output[1]:
        return None
    weight_min = _scalar(model, clip.input[1])
    cover = _node(model, sub.input[1], "Cast")
    marked = _node(model, cover.input[0], "Greater") if cover is not None else None
    if weight_min is None or marked is None or not marked.name.endswith("_uint8_covered"):
        return None
    byte = next((n for n in model.graph.node if n.name == marked.name[:-len("covered")] + "byte"), None)
    start = _const_value(model, byte.input[1]) if byte is not None else None
    if start is None:
        return None
    from morf.raster.neural_raster import COVERAGE_CHANNEL

    if int(start.reshape(-1)[0]) != COVERAGE_CHANNEL:  # sliced from the colour bytes (channels 0-2) or the raster
        return None
    return TailSpec(head=head, fill=fill,
                    colour_scale=tuple(float(v) * dq_scale for v in scale.reshape(-1)),
                    zero_point=int(zp.reshape(-1)[0]), coverage_channel=COVERAGE_CHANNEL,
                    logit_scale=float(k), logit_offset=float(c), weight_min=float(weight_min),
                    opaque_margin=int(margin), head_stage=_head_stage(model, head))


def check_tail(model: onnx.ModelProto, spec: TailSpec, rasters: Sequence[np.ndarray]) -> dict:
    """The compiled tail against the whole graph ``model`` on ``rasters`` (NHWC uint8), over a
    white and a black background: the largest difference in levels, the share of pixel channels
    that differ, the number of views. One session of the whole graph gives the image and the
    tail's two inputs."""
    import onnxruntime as ort

    model = onnx.ModelProto.FromString(model.SerializeToString())  # the caller's graph stays as it is
    model.graph.output.extend([onnx.helper.make_empty_tensor_value_info(n) for n in spec.cut])
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 2
    whole = ort.InferenceSession(model.SerializeToString(), opts, providers=["CPUExecutionProvider"])
    shader = TailShader(spec)
    worst, differing, total = 0, 0, 0
    for r in rasters:
        for value in (255.0, 0.0):
            bg = np.full((1, 3, 1, 1), value, np.float32)
            image, *cut = whole.run(["image", *spec.cut], {"raster": r, "background": bg})
            d = np.abs(shader.run(cut, r, bg).astype(np.int16) - image[0].astype(np.int16))
            worst, differing, total = max(worst, int(d.max())), differing + int((d > 0).sum()), total + d.size
    return {"max_levels": worst, "share_differing": differing / max(total, 1), "views": len(rasters)}


def native_tail_entry(path: Path, layout: str, rasters: Sequence[np.ndarray]) -> dict | None:
    """The manifest entry for the graph at ``path``: the spec with its check, or None when the graph
    has no such tail, numba is missing or the check fails (the player then runs the whole graph)."""
    model = onnx.load(str(path))
    spec = tail_spec(model, layout)
    if spec is None or not numba_available() or not rasters:
        return None
    check = check_tail(model, spec, rasters)
    if check["max_levels"] > MAX_LEVELS or check["share_differing"] > MAX_SHARE:
        return None
    return dataclasses.replace(spec, check=check).to_dict()

