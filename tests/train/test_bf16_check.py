"""The bfloat16 self-check: autocast is kept off where this machine's bfloat16 convolutions
disagree with float32, whatever the CPU's flags say."""

import torch
import torch.nn.functional as F
from torch import nn

import morf.train.bf16_check as check
from morf.train.bf16_check import BF16_TOLERANCE, bf16_disagreement


def test_rounding_alone_passes():
    net = nn.Sequential(nn.Conv2d(8, 8, 3, 1, 1), nn.LeakyReLU(0.2), nn.Conv2d(8, 16, 3, 2, 1))
    err, where = bf16_disagreement([net, None])
    assert err < BF16_TOLERANCE
    assert bf16_disagreement([nn.Linear(3, 3)]) == (0.0, "")


def test_a_wrong_kernel_is_found_and_named(monkeypatch):
    """A convolution that autocast computes wrongly (as one CPU's bfloat16 stride-4 stem did)."""
    real = F.conv2d

    def broken(x, w, b=None, stride=1, padding=0, dilation=1, groups=1):
        y = real(x, w, b, stride, padding, dilation, groups)
        if torch.is_autocast_enabled("cpu") and w.shape[-1] == 4:
            return y.flip(1)  # the right numbers in the wrong channels
        return y

    monkeypatch.setattr(check.F, "conv2d", broken)
    net = nn.Sequential(nn.Conv2d(16, 16, 4, 4), nn.Conv2d(16, 16, 3, 1, 1))
    err, where = bf16_disagreement([net])
    assert err > BF16_TOLERANCE and where.startswith("0 (16->16 channels, kernel 4x4, stride 4")


def test_channels_last_layers_are_checked_in_that_layout(monkeypatch):
    seen = []
    real = F.conv2d

    def spy(x, w, *a):
        seen.append(x.is_contiguous(memory_format=torch.channels_last))
        return real(x, w, *a)

    monkeypatch.setattr(check.F, "conv2d", spy)
    bf16_disagreement([nn.Conv2d(16, 16, 3, 1, 1).to(memory_format=torch.channels_last)])
    assert seen == [True, True]
