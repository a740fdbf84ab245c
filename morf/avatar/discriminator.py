"""Multi-scale PatchGAN discriminator (pix2pix / pix2pixHD) for the adversarial loss.

Each scale is a PatchGAN on an average-pooled copy of the image; every scale returns its
intermediate features too, used for feature matching when no VGG weights are available.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


class PatchDiscriminator(nn.Module):
    """70x70-style PatchGAN: 4x4 convs, stride 2, LeakyReLU; instance norm after the first layer."""

    def __init__(self, in_channels: int = 4, width: int = 32, layers: int = 3):
        super().__init__()
        blocks = [nn.Sequential(nn.Conv2d(in_channels, width, 4, 2, 1), nn.LeakyReLU(0.2, inplace=True))]
        ch = width
        for i in range(1, layers + 1):
            nxt = min(ch * 2, width * 8)
            stride = 2 if i < layers else 1
            blocks.append(nn.Sequential(nn.Conv2d(ch, nxt, 4, stride, 1), nn.InstanceNorm2d(nxt),
                                        nn.LeakyReLU(0.2, inplace=True)))
            ch = nxt
        blocks.append(nn.Conv2d(ch, 1, 4, 1, 1))
        self.blocks = nn.ModuleList(blocks)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        """(B, Cin, H, W) -> features of every block; the last item is the (B, 1, h, w) logits."""
        feats = []
        for b in self.blocks:
            x = b(x)
            feats.append(x)
        return feats


class MultiScaleDiscriminator(nn.Module):
    """``scales`` PatchGANs on the image at 1, 1/2, 1/4, ... resolution."""

    def __init__(self, in_channels: int = 4, width: int = 32, layers: int = 3, scales: int = 2):
        super().__init__()
        self.nets = nn.ModuleList(PatchDiscriminator(in_channels, width, layers) for _ in range(scales))

    def forward(self, x: torch.Tensor) -> list[list[torch.Tensor]]:
        out = []
        for i, net in enumerate(self.nets):
            if i > 0:
                x = F.avg_pool2d(x, 3, 2, 1, count_include_pad=False)
            out.append(net(x))
        return out
