"""Does this machine's bfloat16 autocast compute the model's convolutions right? Checked, not assumed.

A CPU with native bfloat16 can still get a wrong kernel: on an Intel Xeon with AMX (torch 2.13,
oneDNN), a bfloat16 convolution whose kernel equals its stride (4 or 8) and that reads 16 or more
channels returned values unrelated to the float32 ones (relative RMS error 1.16; 8 input channels,
or kernel 4 with stride 2, were right, 0.002). The `cpu` preset's stride-4 stem is such a layer. A
renderer trained through it learns to need it: rendered in float32 (evaluation, export, the int8
player) its mask came out 13 % larger than the person, person SSIM 0.59 instead of 0.72.

:func:`bf16_disagreement` runs each distinct convolution of the given modules once in float32
and once under autocast, on random data of the layer's own shape and memory layout, and reports
the worst relative error; the trainer keeps autocast off when it is above
:data:`BF16_TOLERANCE`. Correct kernels differ by bfloat16 rounding only (about 0.002).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

# train.log's words when a CPU has no bfloat16 in hardware (the trainer does not try it there)
OFF_NOT_NATIVE = "off (this CPU has neither AMX-BF16 nor AVX512-BF16; emulated it is slower)"
BF16_TOLERANCE = 0.05  # relative RMS error; rounding alone gives about 0.002, the broken kernel 1.16
CHECK_SIDE = 64  # input side of the check (the wrong kernel above was wrong at 64, 128 and 256)


def _signature(conv: nn.Conv2d) -> tuple:
    channels_last = conv.weight.is_contiguous(memory_format=torch.channels_last) and conv.weight.shape[1] > 1
    return (conv.in_channels, conv.out_channels, conv.kernel_size, conv.stride, conv.padding, conv.dilation,
            conv.groups, channels_last)


def bf16_disagreement(modules, device: torch.device | str = "cpu", seed: int = 0) -> tuple[float, str]:
    """The worst relative RMS error of bfloat16 autocast against float32 over the distinct
    convolutions of ``modules`` (``None`` entries are skipped), and which layer it was.

    Returns ``(0.0, "")`` for modules without convolutions.
    """
    device = torch.device(device)
    gen = torch.Generator().manual_seed(seed)
    seen, worst, where = set(), 0.0, ""
    for module in modules:
        if module is None:
            continue
        for name, conv in module.named_modules():
            if not isinstance(conv, nn.Conv2d):
                continue
            sig = _signature(conv)
            if sig in seen:
                continue
            seen.add(sig)
            cin, cout, k, s, p, d, g, channels_last = sig
            x = torch.randn(1, cin, CHECK_SIDE, CHECK_SIDE, generator=gen)
            w = torch.randn(cout, cin // g, *k, generator=gen) / (cin // g * k[0] * k[1]) ** 0.5
            b = torch.randn(cout, generator=gen)
            x, w, b = x.to(device), w.to(device), b.to(device)
            if channels_last:
                x, w = x.contiguous(memory_format=torch.channels_last), w.contiguous(memory_format=torch.channels_last)
            with torch.no_grad():
                ref = F.conv2d(x, w, b, s, p, d, g)
                with torch.autocast(device.type, dtype=torch.bfloat16):
                    got = F.conv2d(x, w, b, s, p, d, g).float()
            err = float((got - ref).pow(2).mean().sqrt() / ref.pow(2).mean().sqrt().clamp_min(1e-12))
            if err > worst:
                worst, where = err, (f"{name} ({cin}->{cout} channels, kernel {k[0]}x{k[1]}, "
                                     f"stride {s[0]}{', channels-last' if channels_last else ''})")
    return worst, where
