"""The renderer as ONNX: fp32 and int8 (static QDQ), both reading the uint8 neural rasterization.

Graph contract (both files):
    input  "raster": uint8, (1, 16, H, W) ("nchw") or (4, H, W, 4) ("planes", the GL attachments),
           value = 128 + round(feature / scale[c]); 128 is background.
    output "rgba":  float32 (1, 4, H, W): RGB premultiplied by the mask in [0, 1], then the mask
           probability (the sigmoid of the renderer's mask logit is taken in the graph).
H and W are free (multiples of the renderer's ``cfg.multiple``).

The per-channel texture scales are folded into the first convolutions' weights, so the graph
starts with one ``DequantizeLinear(1/127, 128)`` (fp32) or directly with uint8 convolutions
(int8: the input's quantisation parameters are pinned to exactly 1/127 and 128).
"""

from __future__ import annotations

import io
import os
import tempfile
import warnings
from pathlib import Path
from typing import Iterable

import numpy as np
import onnx

from morf.export.onnx_graph import fold_input_scale, uint8_input
from morf.export.texture_quant import ZERO_POINT

FLOAT_INPUT = "x"
OPSET = 17


def logit_scale(renderer, scales: np.ndarray, rasters: Iterable[np.ndarray]) -> float:
    """How much the mask logit must shrink to share one int8 range with the colours (>= 1).

    A trained renderer's mask logit spans tens of units while its linear RGB spans about one; in
    one per-tensor int8 range the logit would swamp the colours. The exported graph computes
    ``logit / k`` in the last convolution and multiplies by ``k`` before the sigmoid (one
    convolution instead of two: a 1-channel convolution at full resolution costs as much as a
    4-channel one). ``k`` = the logit's largest magnitude over the colours' on the calibration views.
    """
    import torch

    cfg = getattr(renderer, "cfg", None)
    used = int(getattr(cfg, "in_channels", len(scales)))
    if not hasattr(renderer, "features"):
        return 1.0
    s = torch.as_tensor(np.asarray(scales, np.float32)).view(1, -1, 1, 1)
    rgb_max, logit_max = 1e-3, 0.0
    with torch.no_grad():
        for r in rasters:
            x = (torch.as_tensor(np.asarray(r, np.float32)) - ZERO_POINT) * s
            out = renderer.last(renderer.features(x[:, :used]))
            rgb_max = max(rgb_max, float(out[:, :3].abs().max()))
            logit_max = max(logit_max, float(out[:, 3].abs().max()))
    return max(1.0, logit_max / max(rgb_max, 0.5))


def _export_float_graph(renderer, scales: np.ndarray, sample_hw: tuple[int, int],
                        mask_scale: float = 1.0) -> onnx.ModelProto:
    """Export ``renderer(x * 127 * scales)`` with output RGB + sigmoid(mask) and fold the scale.

    A renderer with fewer input channels than the 16 GL channels (small presets) reads the first
    ones; the texture's extra channels are zero (128) and the scale then stays a ``Mul``.
    ``mask_scale``: see :func:`logit_scale` (1 for the fp32 graph).
    """
    import torch

    cfg = getattr(renderer, "cfg", None)
    used = int(getattr(cfg, "in_channels", len(scales)))
    split = hasattr(renderer, "features") and isinstance(getattr(renderer, "last", None), torch.nn.Conv2d)

    class _Wrapper(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.renderer = renderer
            self.register_buffer("scale", torch.as_tensor(127.0 * np.asarray(scales, np.float32)).view(1, -1, 1, 1))

        def forward(self, x):
            x = x * self.scale
            x = x if used == x.shape[1] else x[:, :used]
            if not split:
                out = self.renderer(x)
                return torch.cat([out[:, :3], torch.sigmoid(out[:, 3:4])], dim=1)
            last = self.renderer.last
            k = torch.ones(4, 1, 1, 1)
            k[3] = mask_scale
            out = torch.nn.functional.conv2d(self.renderer.features(x), last.weight / k, last.bias / k.view(-1),
                                             stride=last.stride, padding=last.padding)
            rgb, mask = out[:, :3], torch.sigmoid(out[:, 3:4] * mask_scale if mask_scale != 1 else out[:, 3:4])
            if getattr(cfg, "premultiply", False):
                rgb = rgb * mask
            return torch.cat([rgb, mask], dim=1)

    wrapper = _Wrapper().eval().float()
    x = torch.zeros(1, len(scales), *sample_hw)
    buf = io.BytesIO()
    with warnings.catch_warnings(), torch.no_grad():
        warnings.simplefilter("ignore")
        torch.onnx.export(wrapper, (x,), buf, opset_version=OPSET, dynamo=False, input_names=[FLOAT_INPUT],
                          output_names=["rgba"], do_constant_folding=True,
                          dynamic_axes={FLOAT_INPUT: {2: "height", 3: "width"}, "rgba": {2: "height", 3: "width"}})
    model = onnx.load_from_string(buf.getvalue())
    if not fold_input_scale(model, FLOAT_INPUT):
        warnings.warn("renderer input scale could not be folded into the first convolutions; kept as a Mul")
    return model


def export_fp32(renderer, scales: np.ndarray, path: str | os.PathLike, layout: str = "nchw",
                sample_hw: tuple[int, int] = (128, 128)) -> None:
    """Write the fp32 renderer with a uint8 input (see module docstring)."""
    model = uint8_input(_export_float_graph(renderer, scales, sample_hw), FLOAT_INPUT, layout)
    onnx.checker.check_model(model)
    _save(model, path)


class _Calibration:
    """onnxruntime CalibrationDataReader over uint8 (1, 16, H, W) rasterizations."""

    def __init__(self, rasters: Iterable[np.ndarray]):
        self._it = iter(rasters)

    def get_next(self):
        r = next(self._it, None)
        if r is None:
            return None
        return {FLOAT_INPUT: ((np.asarray(r, np.float32) - ZERO_POINT) / 127.0)}


def export_int8(renderer, scales: np.ndarray, path: str | os.PathLike, calibration: Iterable[np.ndarray],
                layout: str = "nchw", sample_hw: tuple[int, int] = (128, 128)) -> None:
    """Write the int8 renderer: static QDQ, per-channel int8 weights, uint8 activations.

    Args:
        calibration: uint8 (1, 16, H, W) neural rasterizations (the capture's own training views).
    """
    from onnxruntime.quantization import CalibrationMethod, QuantFormat, QuantType, quantize_static
    from onnxruntime.quantization.shape_inference import quant_pre_process

    calibration = list(calibration)
    model = _export_float_graph(renderer, scales, sample_hw, logit_scale(renderer, scales, calibration))
    with tempfile.TemporaryDirectory() as tmp:
        f32, pre, q8 = (Path(tmp) / n for n in ("f32.onnx", "pre.onnx", "q8.onnx"))
        onnx.save(model, f32)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            quant_pre_process(str(f32), str(pre), skip_symbolic_shape=True)
            quantize_static(str(pre), str(q8), _Calibration(calibration), quant_format=QuantFormat.QDQ,
                            per_channel=True, activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8,
                            calibrate_method=CalibrationMethod.MinMax,
                            extra_options={"TensorQuantOverrides": {FLOAT_INPUT: [
                                {"scale": np.array(1 / 127, np.float32), "zero_point": np.array(ZERO_POINT, np.uint8)}]}})
        q = onnx.load(q8)
    q = uint8_input(q, FLOAT_INPUT, layout, quantized=True)
    onnx.checker.check_model(q)
    _save(q, path)


def _save(model: onnx.ModelProto, path: str | os.PathLike) -> None:
    from morf.io import atomic_path

    with atomic_path(path) as tmp:
        onnx.save(model, str(tmp))
