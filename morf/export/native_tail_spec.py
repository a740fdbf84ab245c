"""The renderer graph's full-resolution tail for the player's compiled pass
(:mod:`morf.export.compiled_tail`), from what the exporter knows, and that pass checked against
the whole graph.

The exporter (:mod:`morf.export.onnx_renderer`) hands over the tail's constants
(:class:`TailParameters`: the texture colour's scale, the mask channel's map to the logit, the
half-resolution head's last weights) and names two tensors of the graph it traces: the head
before its 2x upsampling (:data:`TAIL_HEAD`) and the texture colour (:data:`TAIL_COLOUR`). The
graph gives only what calibration and the fill's levels decide: the fill's finest pull level (the
tensor upsampled into the colour) and its weight floor, and for int8 graphs the two tensors the
head's last layers read and the scale of the quantized one. A graph without the tail (a
full-resolution head, no colour skip, another layout) gets no spec and plays through the whole
graph; every spec is checked against the graph before it goes into the manifest.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import onnx

from morf.export.compiled_tail import HeadStage, TailShader, TailSpec
from morf.export.onnx_graph import attr, const_value, producer
from morf.raster.neural_raster import COVERAGE_CHANNEL
from morf.raster.texture_quant import ZERO_POINT

TAIL_HEAD = "tail_head"  # (1, 4, H/2, W/2): the head's residual RGB + mask channel before the 2x upsampling
TAIL_COLOUR = "tail_colour"  # (1, 3, H, W): the texture colour the residual is added to
MAX_LEVELS = 2  # the most a pixel channel may differ from the whole graph's (rounding)
MAX_SHARE = 1e-3  # the share of pixel channels allowed to differ at all


@dataclass(frozen=True)
class TailParameters:
    """The tail's constants as the exporter set them.

    Fields:
        colour_scale: (3,) texture colour per byte step (the texture's scales of channels 0-2).
        logit_scale, logit_offset: the mask channel's map to the logit (1 and 0 in fp32 graphs).
        head_weight: (4, C) and head_bias: (4,) of the head's last 1x1 convolution (the mask row
            already mapped); head_alpha: the LeakyReLU slope before it.
    """

    colour_scale: tuple[float, float, float]
    logit_scale: float
    logit_offset: float
    head_weight: tuple[tuple[float, ...], ...]
    head_bias: tuple[float, ...]
    head_alpha: float


def _node(model, name: str, op: str):
    n = producer(model, name)
    return n if n is not None and n.op_type == op else None


def _other(node, name: str) -> str | None:
    """The input of a two-input node that is not ``name``."""
    ins = list(node.input)
    if len(ins) != 2 or name not in ins:
        return None
    return ins[1] if ins[0] == name else ins[0]


def _uncast(model, name: str) -> str:
    """``name``, or what a chain of no-op float Casts before it reads (torch's ``.to(dtype)``)."""
    n = producer(model, name)
    while n is not None and n.op_type == "Cast" and attr(n, "to") == onnx.TensorProto.FLOAT:
        name = n.input[0]
        n = producer(model, name)
    return name


def _scalar(model, name: str) -> float | None:
    v = const_value(model, name)
    return None if v is None or v.size != 1 else float(v.reshape(-1)[0])


def _resized(model, name: str, sizes_ok: bool = False) -> str | None:
    """The input of the 2x bilinear half-pixel Resize that makes ``name``, or None. ``sizes_ok``:
    also a Resize to computed ``sizes`` (the fill's last pull step resizes to the frame's size:
    twice its input's side on the even sides the player renders; the pass checks the shapes each
    frame)."""
    rs = _node(model, name, "Resize")
    if rs is None or attr(rs, "mode") not in (b"linear", "linear") \
            or attr(rs, "coordinate_transformation_mode") not in (b"half_pixel", "half_pixel", b"pytorch_half_pixel", "pytorch_half_pixel"):
        return None
    scales = const_value(model, rs.input[2]) if len(rs.input) > 2 and rs.input[2] else None
    if scales is not None and list(scales.reshape(-1)) == [1.0, 1.0, 2.0, 2.0]:
        return rs.input[0]
    if sizes_ok and scales is None and len(rs.input) > 3 and rs.input[3]:
        return rs.input[0]
    return None


def _upsampled(model, name: str) -> str | None:
    """The input of the 2x Resize that makes ``name`` through a Split of 3 + 1 channels."""
    split = producer(model, name)
    if split is None or split.op_type != "Split" or list(split.input[:1]) == [] or attr(split, "axis") not in (1, -3):
        return None
    sizes = const_value(model, split.input[1]) if len(split.input) > 1 else None
    if sizes is None or list(sizes.reshape(-1)) != [3, 1]:
        return None
    return _resized(model, split.input[0], sizes_ok=True)


def _head_stage(model, head: str, params: TailParameters) -> HeadStage | None:
    """The int8 graph's half-resolution head before ``head``: ``Reshape(Add(MatMul(weight,
    Reshape(LeakyRelu(Add(Resize2x(low), DequantizeLinear(skip))))), bias))``; None otherwise
    (the fp32 graph's last 1x1 convolution has weights computed in the graph, so it stays there).
    The weights and the slope are the exporter's; the graph gives the two tensors to cut at and
    the scale calibration chose for ``skip``."""
    out = _node(model, head, "Reshape")
    add = _node(model, out.input[0], "Add") if out is not None else None
    mm_out = next((i for i in add.input if _node(model, i, "MatMul") is not None), None) if add is not None else None
    if mm_out is None:
        return None
    flat = _node(model, producer(model, mm_out).input[1], "Reshape")
    act = _node(model, flat.input[0], "LeakyRelu") if flat is not None else None
    total = _node(model, act.input[0], "Add") if act is not None else None
    if total is None:
        return None
    low = next((_resized(model, i) for i in total.input if _resized(model, i) is not None), None)
    if low is None:
        return None
    skip = next(i for i in total.input if _resized(model, i) is None)
    scale, zp = 1.0, 0
    dq = _node(model, skip, "DequantizeLinear")
    if dq is not None:
        scale, zero = _scalar(model, dq.input[1]), const_value(model, dq.input[2])
        if scale is None or zero is None or zero.size != 1:
            return None
        skip, zp = dq.input[0], int(zero.reshape(-1)[0])
    return HeadStage(low=low, skip=skip, skip_scale=float(scale), skip_zero_point=zp, alpha=params.head_alpha,
                     weight=params.head_weight, bias=params.head_bias)


def _fill(model, colour: str) -> tuple[str, float] | None:
    """The fill's finest pull level (upsampled 2x into the colour) and its weight floor, from the
    texture colour the exporter named: ``colour = tex + up(FILL)[:3] * ((1 - covered) /
    max(up(FILL)[3], weight_min))``; None when the graph computes it otherwise."""
    add = _node(model, colour, "Add")
    if add is None:
        return None
    fill_mul = None
    for i in add.input:
        n = producer(model, _uncast(model, i))
        if n is not None and n.op_type == "Mul" and any(_node(model, j, "Div") is not None for j in n.input):
            fill_mul = n
    if fill_mul is None:
        return None
    div = next(_node(model, i, "Div") for i in fill_mul.input if _node(model, i, "Div") is not None)
    fill_rgb = _other(fill_mul, div.output[0])
    fill = _upsampled(model, fill_rgb) if fill_rgb is not None else None
    clip = _node(model, div.input[1], "Clip")
    if fill is None or clip is None or list(producer(model, fill_rgb).output) != [fill_rgb, clip.input[0]]:
        return None
    weight_min = _scalar(model, clip.input[1])
    return None if weight_min is None else (fill, weight_min)


def tail_spec(model: onnx.ModelProto, params: TailParameters | None, layout: str, coverage: bool,
              opaque_margin: int) -> TailSpec | None:
    """The tail of a renderer graph the exporter has just finished (see the module docstring), or
    None where it has none: another layout, no colour skip or half-resolution head (``params``
    None), no coverage byte (``coverage`` False), or a graph that computes it otherwise."""
    names = {o.name for o in model.graph.output}
    if params is None or layout != "nhwc" or not coverage or not {TAIL_HEAD, TAIL_COLOUR} <= names:
        return None
    fill = _fill(model, TAIL_COLOUR)
    if fill is None or _upsampled_head(model) is None:
        return None
    return TailSpec(head=TAIL_HEAD, fill=fill[0], colour_scale=params.colour_scale, zero_point=ZERO_POINT,
                    coverage_channel=COVERAGE_CHANNEL, logit_scale=params.logit_scale,
                    logit_offset=params.logit_offset, weight_min=float(fill[1]), opaque_margin=int(opaque_margin),
                    head_stage=_head_stage(model, TAIL_HEAD, params))


def _upsampled_head(model) -> str | None:
    """The 2x Resize of the named head that the mask and the residual are split from."""
    readers = [n for n in model.graph.node if TAIL_HEAD in n.input]
    resize = next((n for n in readers if n.op_type == "Resize"), None)
    return None if resize is None else _resized(model, resize.output[0])


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


def native_tail_entry(path: Path, spec: TailSpec | None, rasters: Sequence[np.ndarray]) -> dict | None:
    """The manifest entry for the graph at ``path`` with the tail ``spec`` its exporter wrote: the
    spec with its check, or None when there is no spec, numba is missing or the check fails (the
    player then runs the whole graph)."""
    from morf.machine.compiled import numba_available

    if spec is None or not numba_available() or not rasters:
        return None
    check = check_tail(onnx.load(str(path)), spec, rasters)
    if check["max_levels"] > MAX_LEVELS or check["share_differing"] > MAX_SHARE:
        return None
    return dataclasses.replace(spec, check=check).to_dict()
