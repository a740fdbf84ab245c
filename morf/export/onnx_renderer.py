"""The renderer as ONNX: fp32 and int8 (static QDQ), both reading the uint8 neural rasterization.

Graph contract (both files):
    input  "raster": uint8, (1, H, W, 16) ("nhwc", the GL read-back), (1, 16, H, W) ("nchw") or
           (4, H, W, 4) ("planes"); value = 128 + round(feature / scale[c]); 128 is background.
    input  "background": float32 (1, 3, H, W) image or (1, 3, 1, 1) colour, 0-255.
    output "rgba":  float32 (1, 4, H, W): RGB premultiplied by the mask in [0, 1], then the mask
           probability (the sigmoid of the renderer's mask logit is taken in the graph).
    output "image": uint8 (1, H, W, 3): rgba composited over the background (see
           :func:`morf.export.onnx_graph.append_composite`).
H and W are free (multiples of the renderer's ``cfg.multiple``).

The per-channel texture scales are folded into the first convolutions' weights, so the graph
starts with one ``DequantizeLinear(1/127, 128)`` (fp32) or directly with uint8 convolutions
(int8: the input's quantisation parameters are pinned to exactly 1/127 and 128).
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import numpy as np
import onnx

from morf.export.compiled_tail import TailSpec
from morf.export.native_tail_spec import TAIL_COLOUR, TAIL_HEAD, TailParameters, tail_spec
from morf.export.onnx_graph import (OPAQUE_MARGIN_PX, append_composite, downstream_nodes, fold_input_scale, opaque_body,
                                    uint8_colour_head, uint8_input)
from morf.raster.texture_quant import ZERO_POINT

FLOAT_INPUT = "x"
OPSET = 17


# The colour fill's reach in the exported graphs: the push-pull levels are constants of the
# traced graph, so they are set for frames this large (6 levels; 640 px is the player's default,
# the studio's panel is up to about 1000), not for the small sample the graph is traced at.
FILL_SIDE = 1024

MASK_LOGIT_SPAN = 8.0  # |logit| beyond this is a saturated mask (sigmoid(8) = 0.9997)


def colour_range(renderer, inputs, mask_threshold: float = 0.02) -> tuple[float, float]:
    """Range of the linear RGB head over the pixels that show (mask > threshold), at least [0, 1].

    Where the mask is off the RGB is multiplied by ~0 and may be anything (it reached +-13 on a
    trained renderer); calibrating the shared output range on it cost 4 bits of colour.
    """
    import torch

    lo, hi = 0.0, 1.0
    with torch.no_grad():
        for x in inputs:
            out = renderer.last(renderer.features(x))
            on = (torch.sigmoid(out[:, 3:4]) > mask_threshold).expand(-1, 3, -1, -1)
            rgb = out[:, :3][on]
            if rgb.numel():
                lo, hi = min(lo, float(rgb.min())), max(hi, float(rgb.max()))
    return lo, hi


def widen_input(renderer, channels: int):
    """A copy of a UNetRenderer that reads ``channels`` input channels, the extra ones with zero
    weights (the same function of the first ``cfg.in_channels``). Small presets train on the
    first 4 or 8 texture channels while the GL rasterization always carries 16: reading them all
    keeps the uint8 input folded into the first convolutions, where a channel Slice left a float
    Mul + Slice on the full-resolution input (channels 4 and 8 played slower than 16)."""
    import copy
    import dataclasses

    import torch

    cfg = getattr(renderer, "cfg", None)
    if cfg is None or not hasattr(renderer, "stem") or cfg.in_channels >= channels:
        return renderer
    wide = copy.deepcopy(renderer)
    extra = channels - cfg.in_channels

    def pad(conv: torch.nn.Conv2d, at: int) -> None:
        w = conv.weight.data
        z = torch.zeros(w.shape[0], extra, *w.shape[2:], dtype=w.dtype)
        conv.weight = torch.nn.Parameter(torch.cat([w[:, :at], z, w[:, at:]], dim=1))
        conv.in_channels += extra

    pad(wide.stem[0], cfg.in_channels)
    if cfg.stem > 1 and getattr(cfg, "head_stride", 1) > 1:  # the head reads x through head_x
        pad(wide.head_x, cfg.in_channels)
    elif cfg.stem > 1:  # the full-resolution head reads cat(h, x): x's channels come last
        pad(wide.head[0], wide.head[0].in_channels)
    wide.cfg = dataclasses.replace(cfg, in_channels=channels)
    return wide


def _tail_parameters(renderer, scales: np.ndarray, w, b, k: float, c: float) -> TailParameters | None:
    """What the player's compiled tail needs from this export (:mod:`morf.export.native_tail_spec`),
    for a renderer that has such a tail: a colour skip, premultiplied output and the head at half
    resolution; None otherwise. Numbers as the graph holds them (float32)."""
    cfg = getattr(renderer, "cfg", None)
    if not (getattr(cfg, "rgb_skip", False) and getattr(cfg, "premultiply", False)
            and int(getattr(cfg, "head_stride", 1)) == 2 and getattr(cfg, "stem", 1) > 1):
        return None
    f32 = lambda v: float(np.float32(v))  # noqa: E731
    colour = np.float32(127.0) * np.asarray(scales[:3], np.float32)  # the Mul after DequantizeLinear(1/127)
    weight = w.detach().reshape(w.shape[0], -1).double().numpy()
    return TailParameters(colour_scale=tuple(float(v) * f32(1 / 127) for v in colour), logit_scale=f32(k),
                          logit_offset=f32(c), head_weight=tuple(tuple(f32(v) for v in row) for row in weight),
                          head_bias=tuple(f32(v) for v in b.detach().double().numpy()),
                          head_alpha=f32(renderer.head[1].negative_slope))


@dataclass(frozen=True)
class _GraphHead:
    """How the exported graph ends, settled before tracing.

    Fields:
        split: the renderer has ``features`` and a ``last`` convolution, which the graph applies
            itself with ``weight`` and ``bias``; otherwise the renderer runs whole.
        k, c: the mask logit is ``k * channel + c`` of the last convolution's mask channel (1, 0
            without an int8 colour range).
        weight, bias: the last convolution's parameters with the mask channel mapped (None
            unless ``split``).
        tail: the player's compiled tail's parameters (:func:`_tail_parameters`), or None.
    """

    split: bool
    k: float = 1.0
    c: float = 0.0
    weight: Any = None
    bias: Any = None
    tail: TailParameters | None = None


def _graph_head(renderer, scales: np.ndarray, colours: tuple[float, float] | None) -> _GraphHead:
    """The :class:`_GraphHead` of ``renderer``; ``colours`` as in :func:`_export_float_graph`."""
    import torch

    split = hasattr(renderer, "features") and isinstance(getattr(renderer, "last", None), torch.nn.Conv2d)
    k, c = 1.0, 0.0
    if colours is not None:
        lo, hi = colours
        k = 2 * MASK_LOGIT_SPAN / (hi - lo)  # logit = k * channel + c
        c = -MASK_LOGIT_SPAN - lo * k
    if not split:
        return _GraphHead(False, k, c)
    with torch.no_grad():
        w, b = renderer.last.weight.clone(), renderer.last.bias.clone()
        w[3] /= k
        b[3] = (b[3] - c) / k
    return _GraphHead(True, k, c, w, b, _tail_parameters(renderer, scales, w, b, k, c))


def _graph_module(renderer, scales: np.ndarray, head: _GraphHead, colours: tuple[float, float] | None):
    """The module the graph is traced from: ``renderer(x * 127 * scales)`` with output RGB +
    sigmoid(mask) (and, with a tail, the two tensors the tail reads)."""
    import torch

    cfg = getattr(renderer, "cfg", None)
    used = int(getattr(cfg, "in_channels", len(scales)))
    split, w, b, k, c, tail = head.split, head.weight, head.bias, head.k, head.c, head.tail

    class _Wrapper(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.renderer = renderer
            self.register_buffer("scale", torch.as_tensor(127.0 * np.asarray(scales, np.float32)).view(1, -1, 1, 1))

        def forward(self, x):
            raw = x
            x = x * self.scale
            x = x if used == x.shape[1] else x[:, :used]
            if not split:
                out = self.renderer(x)
                return torch.cat([out[:, :3], torch.sigmoid(out[:, 3:4])], dim=1)
            last = self.renderer.last
            if getattr(self.renderer, "pointwise_matmul", False) and last.kernel_size == (1, 1):
                out = self.renderer.pointwise(last, self.renderer.features(x), w, b)
            else:
                out = torch.nn.functional.conv2d(self.renderer.features(x), w, b, stride=last.stride,
                                                 padding=last.padding)
            head = out
            if hasattr(self.renderer, "to_full"):
                out = self.renderer.to_full(out)
            # one Split, not two Slices: each Slice copied its full-resolution planes at half speed
            rgb, logit = out.split([3, 1], dim=1)
            logit = logit if colours is None else logit * k + c
            mask = torch.sigmoid(logit)
            colour = None
            if getattr(cfg, "rgb_skip", False):  # the residual over the texture's own colour
                colour = self.renderer.colour(raw, self.scale[:, :3])  # reads the raw input: the scale stays folded
                rgb = rgb + colour
            rgb = rgb * mask if getattr(cfg, "premultiply", False) else rgb
            rgba = torch.cat([rgb, mask], dim=1)
            return (rgba, head, colour) if tail is not None else rgba

    return _Wrapper().eval().float()


def _trace(wrapper, renderer, channels: int, sample_hw: tuple[int, int], tail: bool) -> onnx.ModelProto:
    """``wrapper`` traced to ONNX on a (1, ``channels``, *sample_hw) zero input, with free height
    and width; the colour fill's reach set for player-sized frames (:data:`FILL_SIDE`)."""
    import torch

    cfg = getattr(renderer, "cfg", None)
    x = torch.zeros(1, channels, *sample_hw)
    buf = io.BytesIO()
    colour = getattr(renderer, "colour", None) if getattr(cfg, "rgb_skip", False) else None
    reach = colour.reaching(FILL_SIDE) if colour is not None else contextlib.nullcontext()
    outputs = ["rgba", TAIL_HEAD, TAIL_COLOUR] if tail else ["rgba"]
    with warnings.catch_warnings(), torch.no_grad(), reach:
        warnings.simplefilter("ignore")
        torch.onnx.export(wrapper, (x,), buf, opset_version=OPSET, dynamo=False, input_names=[FLOAT_INPUT],
                          output_names=outputs, do_constant_folding=True,
                          dynamic_axes={FLOAT_INPUT: {2: "height", 3: "width"},
                                        **{o: {2: "height", 3: "width"} for o in outputs}})
    return onnx.load_from_string(buf.getvalue())


def _export_float_graph(renderer, scales: np.ndarray, sample_hw: tuple[int, int],
                        colours: tuple[float, float] | None = None) -> tuple[onnx.ModelProto, str | None, TailParameters | None]:
    """Export ``renderer(x * 127 * scales)`` with output RGB + sigmoid(mask) and fold the scale.

    A renderer with fewer input channels than the 16 GL channels (small presets) reads the first
    ones; the texture's extra channels are zero (128) and the scale then stays a ``Mul``.

    ``colours`` (int8 graphs): the RGB range of :func:`colour_range`. The last convolution then
    writes the mask logit mapped affinely from [-8, 8] onto that range (and the graph maps it
    back before the sigmoid), so one per-tensor int8 range serves both, pinned to ``colours``
    by the caller. Returns the model, the name of the last convolution's output (or None) and
    the tail's parameters (:func:`_tail_parameters`; the graph then has the two named tensors of
    :mod:`morf.export.native_tail_spec` as extra outputs, which :func:`_finish` drops).
    """
    head = _graph_head(renderer, scales, colours)
    wrapper = _graph_module(renderer, scales, head, colours)
    model = _trace(wrapper, renderer, len(scales), sample_hw, head.tail is not None)
    if not fold_input_scale(model, FLOAT_INPUT):
        warnings.warn("renderer input scale could not be folded into the first convolutions; kept as a Mul")
    if not head.split:
        return model, None, None
    if getattr(renderer, "pointwise_matmul", False):  # the last 1x1 convolution is a MatMul (+ bias Add)
        last_node = _head_output(model)
        if last_node is not None:
            return model, last_node, head.tail
    convs = [n for n in model.graph.node if n.op_type == "Conv"]
    return model, (convs[-1].output[0] if convs else None), head.tail


def _head_output(model: onnx.ModelProto) -> str | None:
    """The output of the last convolution written as a MatMul: the tensor its bias Add (or, without
    a bias, the MatMul) writes, before the Reshape back to an image."""
    matmuls = [n for n in model.graph.node if n.op_type == "MatMul"]
    if not matmuls:
        return None
    out = matmuls[-1].output[0]
    for op in ("Add", "Reshape"):
        readers = [n for n in model.graph.node if out in n.input]
        if len(readers) == 1 and readers[0].op_type == op:
            out = readers[0].output[0]
    return out


def export_fp32(renderer, scales: np.ndarray, path: str | os.PathLike, layout: str = "nchw",
                sample_hw: tuple[int, int] = (128, 128), opaque: int | None = OPAQUE_MARGIN_PX) -> TailSpec | None:
    """Write the fp32 renderer with a uint8 input (see module docstring). ``opaque``: hold the
    mask at 1 this many pixels inside the body mesh (:func:`~morf.export.onnx_graph.opaque_body`;
    None: the torch renderer's mask as it is). Returns the graph's full-resolution tail for the
    player's compiled pass, unchecked (:mod:`morf.export.native_tail_spec`), or None."""
    model, _, tail = _export_float_graph(widen_input(renderer, len(scales)), scales, sample_hw)
    return _finish(model, path, layout, opaque, quantized=False, tail=tail)


class _Calibration:
    """onnxruntime CalibrationDataReader over uint8 (1, 16, H, W) rasterizations, read whole or a
    range at a time (``set_range``: the calibrator is then fed in chunks, see :func:`chunk_size`)."""

    def __init__(self, rasters: Iterable[np.ndarray]):
        self._rasters = list(rasters)
        self._it = iter(self._rasters)

    def __len__(self) -> int:
        return len(self._rasters)

    def set_range(self, start_index: int, end_index: int) -> None:
        self._it = iter(self._rasters[start_index:end_index])

    def get_next(self):
        r = next(self._it, None)
        if r is None:
            return None
        return {FLOAT_INPUT: ((np.asarray(r, np.float32) - ZERO_POINT) / 127.0)}


# The percentile calibration keeps every activation of the views it is given in memory before it
# histograms them: 5.3 GB for the 24 canvases of 512 px of a `cpu`-preset export in one go. Fed a
# few views at a time (onnxruntime merges the histograms), it keeps only those.
CALIBRATION_CHUNK = 4


def chunk_size(n: int, target: int = CALIBRATION_CHUNK) -> int:
    """The largest number of views up to ``target`` that divides ``n`` (onnxruntime's chunked
    calibration needs equal chunks)."""
    return max(d for d in range(1, max(1, min(target, n)) + 1) if n % d == 0)


def export_int8(renderer, scales: np.ndarray, path: str | os.PathLike, calibration: Iterable[np.ndarray],
                layout: str = "nchw", sample_hw: tuple[int, int] = (128, 128),
                opaque: int | None = OPAQUE_MARGIN_PX) -> dict:
    """Write the int8 renderer: static QDQ, per-channel int8 weights, uint8 activations.

    The renderer is first equalised (``equalize.py``: same function, activation ranges that suit
    one int8 scale per tensor); activation ranges are calibrated at the 99.99th percentile (the
    extreme values of a few pixels cost every other pixel precision) and over the full range, and
    the graph closer to float on the calibration views is kept (:data:`CALIBRATIONS`; the choice
    and both scores are in the model's metadata, ``int8_calibration``); the RGB + mask output of
    the last convolution is pinned to the colour range of the pixels that show.

    Args:
        calibration: uint8 (1, 16, H, W) neural rasterizations (the capture's own training views).
        opaque: as in :func:`export_fp32`.

    Returns ``{"calibration": name, "scores_db": {name: dB}, "native_tail": TailSpec | None}``, the
    calibration kept, each one's :func:`calibration_score` and the tail as :func:`export_fp32`.
    """
    from onnxruntime.quantization import CalibrationMethod, QuantFormat, QuantType, quantize_static
    from onnxruntime.quantization.shape_inference import quant_pre_process

    from morf.export.equalize import dequantized_inputs, equalize_renderer

    renderer = widen_input(renderer, len(scales))
    calibration = list(calibration)
    cfg = getattr(renderer, "cfg", None)
    used = int(getattr(cfg, "in_channels", len(scales)))
    colours = None
    half_head = int(getattr(cfg, "head_stride", 1)) > 1
    overrides = {FLOAT_INPUT: [{"scale": np.array(1 / 127, np.float32), "zero_point": np.array(ZERO_POINT, np.uint8)}]}
    if hasattr(renderer, "features"):
        inputs = dequantized_inputs(calibration, scales, used)
        renderer = equalize_renderer(renderer, inputs)
        colours = colour_range(renderer, inputs)
        renderer.pointwise_matmul = half_head  # on the copy: see float_nodes
    model, last_out, tail = _export_float_graph(renderer, scales, sample_hw, colours)
    if last_out is not None and colours is not None:
        overrides[last_out] = [{"rmin": np.array(colours[0], np.float32), "rmax": np.array(colours[1], np.float32)}]
    with tempfile.TemporaryDirectory() as tmp:
        f32, pre = Path(tmp) / "f32.onnx", Path(tmp) / "pre.onnx"
        onnx.save(model, f32)
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            quant_pre_process(str(f32), str(pre), skip_symbolic_shape=True)
            candidates = {}
            for name, method, extra in CALIBRATIONS:
                candidates[name] = Path(tmp) / f"q8_{name}.onnx"
                quantize_static(str(pre), str(candidates[name]), _Calibration(calibration), quant_format=QuantFormat.QDQ,
                                nodes_to_exclude=float_nodes(model, last_out, half_head),
                                per_channel=True, activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8,
                                calibrate_method=getattr(CalibrationMethod, method),
                                extra_options={**extra, "TensorQuantOverrides": overrides,
                                               "CalibStridedMinMax": chunk_size(len(calibration))})
        views = calibration[::SCORE_EVERY]
        reference = float_outputs(f32, views)
        scores = {name: calibration_score(q8, views, reference) for name, q8 in candidates.items()}
        best = max(scores, key=lambda name: scores[name])
        q = onnx.load(candidates[best])
    q.metadata_props.add(key="int8_calibration", value=f"{best} ({', '.join(f'{k} {v:.1f} dB' for k, v in scores.items())})")
    spec = _finish(q, path, layout, opaque, quantized=True, tail=tail)
    return {"calibration": best, "scores_db": {k: round(v, 2) for k, v in scores.items()}, "native_tail": spec}


# Activation-range calibrations the int8 export tries; it keeps the one whose graph is closest to
# the float graph on the calibration views (:func:`calibration_score`). The 99.99th percentile
# spares most pixels the range of a few extreme ones and usually wins (a `cpu`-preset avatar:
# 49.9 dB against 43.9 with the full range); on an avatar whose renderer had learned extreme
# encoder activations (trained through a wrong bfloat16 kernel, morf/train/bf16_check.py) it
# clipped them and the int8 mask came out a pixel smaller all round: 26.3 dB against 29.8 with
# the full range (docs/playback.md).
CALIBRATIONS = (("percentile", "Percentile", {"CalibPercentile": 99.99}), ("minmax", "MinMax", {}))
SCORE_EVERY = 4  # score the calibrations on every 4th calibration view


def _session(path):
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 2
    return ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])


def float_outputs(f32_path, rasters) -> list[np.ndarray]:
    """The float graph's (4, H, W) RGB + mask on each uint8 rasterization (its input ``x``)."""
    session = _session(f32_path)
    return [session.run(None, feed)[0][0] for feed in iter(_Calibration(rasters).get_next, None)]


def calibration_score(q8_path, rasters, reference: list[np.ndarray]) -> float:
    """How close an int8 graph is to its float graph's outputs ``reference`` (:func:`float_outputs`)
    on the same uint8 rasterizations: the lower of the PSNR over the image and over the person
    (the float mask > 0.5), in dB, RGB on black, over the views."""
    session = _session(q8_path)
    image, person = [], []
    for feed, a in zip(iter(_Calibration(rasters).get_next, None), reference):
        b = session.run(None, feed)[0][0]
        se = (a[:3] - b[:3]) ** 2
        on = a[3] > 0.5
        image.append(float(se.mean()))
        person.append(float(se[:, on].mean()) if on.any() else 0.0)
    db = lambda mse: 10 * np.log10(1.0 / max(float(np.mean(mse)), 1e-12))  # noqa: E731
    return min(db(image), db(person))


DEEPEST_DECODER_BLOCK = ("/up.0/", "/renderer/up.0/")  # kept float by float_nodes


def float_nodes(model: onnx.ModelProto, last_out: str | None, half_head: bool = False) -> list[str]:
    """Nodes the int8 graph keeps in float: everything after the last convolution (the colour
    head, the mask's sigmoid) and the texture-colour fill of an ``rgb_skip`` renderer (pooling
    and division of colours that are themselves the output: 8 bits there would band the image).

    The decoder's deepest block (``up.0``, at 1/32 of the image side) stays float too: it sets
    the mask's large-scale shape, and the mask logit multiplies its error (the head's output times
    10.6 on the default capture's avatar). In int8 the outline came out noisy and half a pixel
    inside fp32's at 640 x 640: 35.9 dB from fp32 over the image in ``morf bench render``, 43.2
    with the block in float, at no measurable cost (the graph 11.6-11.7 ms either way;
    docs/playback.md).

    ``half_head`` (a renderer whose head runs at half resolution, ``head_stride`` 2): the head
    after ``head_low`` too, i.e. the feature branch's 1x1 convolution and upsampling, its sum with
    the raw-input branch and the last convolution (the raw-input branch's strided convolution
    stays int8: it reads the uint8 input directly). In 8 bits their small per-pixel corrections
    drowned in one tensor-wide step: on an avatar trained on real footage the int8 image showed
    blotches the float one has not. They run on a quarter of the pixels and their convolutions
    are matrix products (:meth:`~morf.avatar.renderer.UNetRenderer.pointwise`), so float costs
    little there.
    """
    after = downstream_nodes(model, last_out) if last_out else []
    fill = [n.name for n in model.graph.node if n.name.startswith(("/colour/", "/renderer/colour/"))]
    deepest = [n.name for n in model.graph.node if n.name.startswith(DEEPEST_DECODER_BLOCK)]
    names = after + [n for n in fill + deepest if n not in after]
    if half_head:
        head_low = [n for n in model.graph.node if n.name.startswith(("/head_low/", "/renderer/head_low/"))]
        if head_low:  # the last convolution is downstream of it too
            names += [n for n in downstream_nodes(model, head_low[-1].output[0]) if n not in names]
    return names


def _finish(model: onnx.ModelProto, path: str | os.PathLike, layout: str, opaque: int | None, quantized: bool,
            tail: TailParameters | None) -> TailSpec | None:
    """The steps both graphs end with: the uint8 ``raster`` input in ``layout``, the texture
    colour read from its bytes, the opaque body (``opaque`` pixels; None: none), the composited
    ``image`` output; checked, then written atomically to ``path``. Returns the tail's spec
    (:func:`~morf.export.native_tail_spec.tail_spec`) and drops the outputs that named it."""
    model = uint8_input(model, FLOAT_INPUT, layout, quantized=quantized)
    rewritten = uint8_colour_head(model, layout)
    margin = opaque if opaque is not None and opaque_body(model, opaque) else 0
    append_composite(model)
    coverage = any(r.startswith("coverage") for r in rewritten)
    spec = tail_spec(model, tail, layout, coverage, margin)
    for named in [o for o in model.graph.output if o.name in (TAIL_HEAD, TAIL_COLOUR)]:
        model.graph.output.remove(named)
    onnx.checker.check_model(model)
    _save(model, path)
    return spec


def _save(model: onnx.ModelProto, path: str | os.PathLike) -> None:
    from morf.io import atomic_path

    with atomic_path(path) as tmp:
        onnx.save(model, str(tmp))
