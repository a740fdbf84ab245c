"""Make a trained U-Net renderer friendlier to per-tensor int8 activations, without changing its function.

onnxruntime's static quantisation gives every activation tensor one uint8 range. Two things in a
trained renderer waste that range (measured on a cpu-preset avatar after 3000 steps):

* **Concatenations.** A decoder level concatenates the upsampled deeper features with the
  encoder's skip; their magnitudes differ by up to 8x, and the concatenation shares one scale,
  so the smaller branch loses 3 bits. Worst is the full-resolution head: the upsampled features
  reach about 84 while the neural rasterization is in [-1, 1] with steps of 1/127; in a shared
  range the texture detail that the full-resolution skip exists for was gone.
* **Channels of one tensor.** Hidden channels of the full-resolution head span 2 to 95.

Both are fixed by rescaling, exactly (LeakyReLU and bilinear resizing are positively
homogeneous, convolutions linear): a branch's producing convolution is divided by ``g`` and the
consuming convolution's input channels multiplied by ``g`` (concatenations, one factor per
branch); per hidden channel, the producing convolution's output channel by ``s_c`` and the
consuming convolution's input channel by ``1/s_c`` (cross-layer equalisation, Nagel et al. 2019).
Ranges are measured on the calibration rasterizations.
"""

from __future__ import annotations

import copy
from typing import Iterable

import numpy as np
import torch
from torch import nn

from morf.raster.texture_quant import ZERO_POINT


def _max_abs(renderer, modules: dict[str, nn.Module], inputs: list[torch.Tensor], per_channel: bool = False):
    """Largest |output| of each named module over ``inputs`` (per channel: a (C,) tensor)."""
    rec: dict[str, torch.Tensor] = {}

    def hook(name):
        def f(_m, _i, out):
            v = out.detach().abs().amax(dim=(0, 2, 3)) if per_channel else out.detach().abs().amax()
            rec[name] = v if name not in rec else torch.maximum(rec[name], v)
        return f

    handles = [m.register_forward_hook(hook(n)) for n, m in modules.items()]
    try:
        with torch.no_grad():
            for x in inputs:
                renderer(x)
    finally:
        for h in handles:
            h.remove()
    return rec


def _scale_out(conv: nn.Conv2d, s: torch.Tensor | float) -> None:
    s = torch.as_tensor(s, dtype=conv.weight.dtype)
    conv.weight.mul_(s.view(-1, 1, 1, 1) if s.ndim else s)
    if conv.bias is not None:
        conv.bias.mul_(s)


def _scale_in(conv: nn.Conv2d, s: torch.Tensor | float, start: int, stop: int) -> None:
    s = torch.as_tensor(s, dtype=conv.weight.dtype)
    conv.weight[:, start:stop].mul_(s.view(1, -1, 1, 1) if s.ndim else s)


def equalize_renderer(renderer, inputs: Iterable[torch.Tensor], input_range: float = 1.0):
    """A copy of a ``UNetRenderer`` with the same function and int8-friendlier activation ranges.

    Args:
        renderer: the trained renderer (left unchanged).
        inputs: float (1, C, H, W) renderer inputs (dequantised calibration rasterizations).
        input_range: the magnitude the raw rasterization has inside the exported graph (the
            per-channel texture scales are folded into the first convolutions, so it is [-1, 1]).
    Returns the equalised copy (eval mode).
    """
    r = copy.deepcopy(renderer).eval()
    xs = [x.float() for x in inputs]
    if not xs or not hasattr(r, "down"):
        return r
    D = len(r.down)
    stem = r.cfg.stem > 1
    split_head = stem and getattr(r.cfg, "head_stride", 1) > 1
    pairs = ([(r.head[0], r.head[1], r.head[2])] if stem else []) + [(b[0], b[1], b[2]) for b in list(r.down) + list(r.up)]
    # One pass measures everything: each rescaling below changes only the tensor it targets (the
    # consumer compensates), so no range measured here is changed by another rescaling.
    watch = {f"down{i}": m for i, m in enumerate(r.down)}
    watch.update({f"up{i}": m for i, m in enumerate(r.up)})
    watch["enc0"] = r.enc0
    if stem:
        watch["head_low"] = r.head_low
    watch.update({f"act{j}": act for j, (_, act, _) in enumerate(pairs)})
    rng = _max_abs(r, watch, xs, per_channel=True)
    top = {k: float(v.max()) for k, v in rng.items()}
    with torch.no_grad():
        # decoder level i concatenates [upsampled deeper features, encoder skip]
        for i in range(D):
            src = r.down[D - 1] if i == 0 else r.up[i - 1]
            g = top[f"down{D - 1}" if i == 0 else f"up{i - 1}"] / max(top[f"down{D - 2 - i}" if D - 2 - i >= 0 else "enc0"], 1e-6)
            if g > 0:
                _scale_out(src[2], 1.0 / g)
                _scale_in(r.up[i][0], g, 0, src[2].out_channels)
        if stem and not split_head:  # full-resolution head: [upsampled head_low features, raw rasterization]
            b = top["head_low"] / input_range
            if b > 0:
                _scale_out(r.head_low[0], 1.0 / b)
                _scale_in(r.head[0], b, 0, r.head_low[0].out_channels)
        for j, (first, _, second) in enumerate(pairs):  # cross-layer equalisation of hidden channels
            ch = rng[f"act{j}"].clamp_min(1e-6)
            s = (ch.max() / ch).clamp(max=100.0)  # a dead channel is not blown up
            _scale_out(first, s)
            if j == 0 and split_head:  # head[1] reads head[0](features) + head_x(raster)
                _scale_out(r.head_x, s)
            _scale_in(second, 1.0 / s, 0, second.in_channels)
    return r


def dequantized_inputs(rasters: Iterable[np.ndarray], scales: np.ndarray, channels: int) -> list[torch.Tensor]:
    """uint8 (1, 16, H, W) rasterizations -> the renderer's float inputs (first ``channels``)."""
    s = torch.as_tensor(np.asarray(scales, np.float32)).view(1, -1, 1, 1)
    return [((torch.as_tensor(np.asarray(r, np.float32)) - ZERO_POINT) * s)[:, :channels] for r in rasters]
