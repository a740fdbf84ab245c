"""The rendering network: U-Net from neural rasterization (C channels) to RGB + mask logit.

Layout (all plain Conv2d / LeakyReLU / bilinear Resize / Concat, so it exports to ONNX opset 17
and quantizes to int8 QDQ without exotic ops; no PixelUnshuffle, which exports as a slow 6-D
Transpose):

    input (C, H, W)
      stem: 3x3 conv (stem=1) or a conv with kernel = stride = stem (2 or 4) -> (width, H/s, W/s)
      encoder: ``depth`` levels of [strided 3x3 conv, 3x3 conv], channels doubling (capped)
      decoder: bilinear x2 upsampling + skip concat + two 3x3 convs per level
      head: 3x3 conv at H/s; if stem > 1 it is upsampled bilinearly to H and concatenated with
            the raw input (the full-resolution skip), then two 1x1 convs -> 4 channels.
            With ``head_stride`` 2 the head runs at H/2: the raw input enters through a 2x2
            stride-2 conv, and the 4 outputs are upsampled bilinearly to H (the texture-colour
            skip of ``rgb_skip`` stays at full resolution).

Output ``(B, 4, H, W)``: channels 0-2 are linear RGB, trained towards [0, 1] premultiplied by the
mask (black background; clamp for display), channel 3 is the mask logit. H and W must be multiples
of ``stem * 2**depth``. The RGB head is linear on purpose: an L1 loss through a sigmoid drives the
logits to saturate, activations blew up and the mask channel stopped learning (measured on a tiny
capture). With ``premultiply`` (default) the network multiplies that linear RGB by its own
mask probability, so the background is black by construction: without it the renderer leaked
a constant ~0.015 tint and halos into the background (measured after 400 cpu-preset steps),
which the player composites over the backdrop. The mask bias starts at -2 (p = 0.12, about the person's share of a frame), which gets
the Dice loss off its initial plateau sooner.
"""

from __future__ import annotations

import contextlib
import math

import torch
import torch.nn.functional as F
from torch import nn

from morf.avatar.network_configs import RendererConfig  # noqa: F401  (the renderer's size, torch-free)


MASK_BIAS_INIT = -2.0


def _half(t: torch.Tensor) -> torch.Tensor:
    """The 2x2 mean: on large even sides as a bilinear resize by 1/2 (the same numbers, one Resize
    in ONNX, which onnxruntime runs in about half the time of its AveragePool at 640x640); small or
    odd sides pool with a partial last window. Pooling with ``ceil_mode`` never reaches a side of
    0, so a graph traced at 640 with the fill's deeper levels also runs on smaller images (a
    Resize by 1/2 turns a side of 1 into 0)."""
    if t.shape[-2] % 2 == 0 and t.shape[-1] % 2 == 0 and min(t.shape[-2:]) >= 64:
        return F.interpolate(t, scale_factor=0.5, mode="bilinear", align_corners=False)
    return F.avg_pool2d(t, 2, 2, ceil_mode=True)


def push_pull_fill(rgb: torch.Tensor, covered: torch.Tensor, levels: int) -> torch.Tensor:
    """Fill uncovered pixels of ``rgb`` (B, 3, H, W) with the colour of nearby covered ones.

    Push: average colour and coverage over 2x2 blocks ``levels`` times (colour stays
    premultiplied by coverage); pull: from the coarsest level up, a pixel keeps its own
    normalised colour as far as it is covered and takes the upsampled coarser colour for the
    rest. The pull carries a weight beside the colour (the coarser levels' coverage) and divides
    by it at the end, so an upsampled value that mixes covered and empty coarse pixels keeps the
    covered ones' colour instead of fading towards black. Covered pixels come back unchanged;
    uncovered pixels within about ``2**levels`` pixels of the body get its colour, farther ones
    black. ``covered`` must be 0 or 1 (the rasterizer's coverage) and ``rgb`` zero where it is 0
    (a rasterization is). Only resizing, division and elementwise arithmetic, so it exports to
    ONNX as plain ops.
    """
    if levels <= 0:
        return rgb
    cols, covs = [rgb], [covered]
    for _ in range(levels):
        cols.append(_half(cols[-1]))
        covs.append(_half(covs[-1]))
    acc = torch.cat([cols[-1], covs[-1]], dim=1)  # colour x weight, weight
    for col, cov in zip(reversed(cols[1:-1]), reversed(covs[1:-1])):
        up = F.interpolate(acc, size=col.shape[-2:], mode="bilinear", align_corners=False)
        a = (cov * 4).clamp(max=1.0)  # a quarter covered is enough to trust the level's own colour
        own = torch.cat([col / cov.clamp_min(1e-4), torch.ones_like(cov)], dim=1)
        acc = a * own + (1 - a) * up
    # Full resolution: the coverage is 0 or 1 there and rgb is zero where it is 0, so the pull
    # step reduces to adding the coarser colour where uncovered, written as arithmetic (covered
    # pixels keep their colour bit for bit; onnxruntime's Where, broadcasting the mask over the
    # planes, was slower). In the playback graph every op here runs at full resolution: one Split
    # of the upsampled colour and weight (two Slices copied the planes twice as slowly), and the
    # division and the uncovered mask on the one weight plane before a single three-plane product.
    up, weight = F.interpolate(acc, size=rgb.shape[-2:], mode="bilinear", align_corners=False).split([3, 1], dim=1)
    return rgb + (up * ((1 - covered) / weight.clamp_min(1e-4))).to(rgb.dtype)


def _block(cin: int, cout: int, stride: int = 1) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, stride, 1), nn.LeakyReLU(0.2, inplace=True),
                         nn.Conv2d(cout, cout, 3, 1, 1), nn.LeakyReLU(0.2, inplace=True))


def fill_levels_for(height: int, width: int, levels: int) -> int:
    """Push-pull levels for an image: at least ``levels`` (0 stays 0: no fill), and enough that
    ``2**levels`` is ``1 / FILL_REACH`` of the smaller side, so the fill reaches as far across the
    person at every image side (4 levels at 256 px, the `cpu` preset's training side; 6 at 640)."""
    if levels <= 0:
        return 0
    return max(levels, math.ceil(math.log2(max(min(height, width), 1) / FILL_REACH)))


FILL_REACH = 16

class TextureColour(nn.Module):
    """The colour the renderer's residual is added to (``rgb_skip``): texture channels 0-2,
    filled off the mesh by :func:`push_pull_fill` (a pixel is on the mesh where any of its
    texture channels is non-zero: the rasterization is exactly zero off the body). A module of its
    own so the int8 exporter can find its nodes and keep them in float.

    The fill's levels grow with the image (:func:`fill_levels_for`). With a fixed count it faded
    to black ``2**levels`` pixels from the body whatever the size: enough at the training side,
    but at 2-2.5x that side (evaluation at the capture's size, playback at 640) a loose trouser
    leg's edge past the fitted body fell outside the fill's reach and showed as a dark band
    (docs/avatar.md)."""

    def __init__(self, levels: int):
        super().__init__()
        self.levels = levels
        self.min_side = 0  # reach as far as at this side at least (the exporter's trace, see below)

    @contextlib.contextmanager
    def reaching(self, side: int):
        """Within the block, fill as far as at an image side of ``side`` pixels whatever the input's
        size. The ONNX exporter traces the graph on a small sample and the levels become constants
        of the graph: traced at 128 px, the player's 640 px frames got the 4 levels of 128."""
        before = self.min_side
        self.min_side = side
        try:
            yield self
        finally:
            self.min_side = before

    def forward(self, x: torch.Tensor, scale: torch.Tensor | None = None) -> torch.Tensor:
        """(B, C, H, W) rasterization -> (B, 3, H, W) colour; ``scale`` (1, 3, 1, 1) multiplies
        channels 0-2 first (the exporter feeds the unscaled input, so its scale stays folded)."""
        x = x.float()
        covered = (x.abs().sum(1, keepdim=True) > 0).to(x.dtype)
        rgb = x[:, :3] if scale is None else x[:, :3] * scale
        side = max(min(x.shape[-2:]), self.min_side)
        return push_pull_fill(rgb, covered, fill_levels_for(side, side, self.levels))


class UNetRenderer(nn.Module):
    """(B, C, H, W) neural rasterization -> (B, 4, H, W) linear premultiplied RGB + mask logit."""

    pointwise_matmul = False  # see :meth:`pointwise` (set on the exporter's copy only)

    def __init__(self, cfg: RendererConfig = RendererConfig()):
        super().__init__()
        if cfg.stem not in (1, 2, 4):
            raise ValueError("renderer stem must be 1, 2 or 4")
        if cfg.head_stride not in (1, 2) or (cfg.head_stride > 1 and cfg.stem == 1):
            raise ValueError("renderer head_stride must be 1, or 2 with a stem of 2 or 4")
        self.cfg = cfg
        ch = [min(cfg.width * 2 ** i, cfg.max_width) for i in range(cfg.depth + 1)]
        if cfg.stem == 1:
            self.stem = nn.Sequential(nn.Conv2d(cfg.in_channels, ch[0], 3, 1, 1), nn.LeakyReLU(0.2, inplace=True))
        else:
            self.stem = nn.Sequential(nn.Conv2d(cfg.in_channels, ch[0], cfg.stem, cfg.stem), nn.LeakyReLU(0.2, inplace=True))
        self.enc0 = nn.Sequential(nn.Conv2d(ch[0], ch[0], 3, 1, 1), nn.LeakyReLU(0.2, inplace=True))
        self.down = nn.ModuleList(_block(ch[i], ch[i + 1], stride=2) for i in range(cfg.depth))
        self.up = nn.ModuleList(
            nn.Sequential(nn.Conv2d(ch[i + 1] + ch[i], ch[i], 3, 1, 1), nn.LeakyReLU(0.2, inplace=True),
                          nn.Conv2d(ch[i], ch[i], 3, 1, 1), nn.LeakyReLU(0.2, inplace=True))
            for i in reversed(range(cfg.depth)))
        if cfg.stem == 1:
            self.head = nn.Conv2d(ch[0], 4, 3, 1, 1)
        else:
            self.head_low = nn.Sequential(nn.Conv2d(ch[0], ch[0], 3, 1, 1), nn.LeakyReLU(0.2, inplace=True))
            # head_stride 1: head[0] reads cat(upsampled features, raw input); 2: the features alone,
            # and head_x the raw input (summed before head[1])
            reads = ch[0] + (cfg.in_channels if cfg.head_stride == 1 else 0)
            self.head = nn.Sequential(nn.Conv2d(reads, cfg.skip_hidden, 1),
                                      nn.LeakyReLU(0.2, inplace=True), nn.Conv2d(cfg.skip_hidden, 4, 1))
            if cfg.head_stride > 1:
                self.head_x = nn.Conv2d(cfg.in_channels, cfg.skip_hidden, cfg.head_stride, cfg.head_stride,
                                        bias=False)
        if cfg.rgb_skip:
            self.colour = TextureColour(cfg.fill_levels)
        with torch.no_grad():
            self.last.bias[3] = MASK_BIAS_INIT
            if cfg.rgb_skip:
                self.last.weight[:3].zero_()
                self.last.bias[:3].zero_()

    @property
    def last(self) -> nn.Conv2d:
        """The final convolution: 3 linear RGB channels and the mask logit."""
        return self.head if self.cfg.stem == 1 else self.head[-1]

    def trunk(self, x: torch.Tensor) -> torch.Tensor:
        """The U-Net from the stem to its last decoder level (at 1/stem of the input size)."""
        h = self.enc0(self.stem(x))
        skips = [h]
        for layer in self.down:
            skips.append(layer(skips[-1]))
        h = skips.pop()
        for layer in self.up:
            h = F.interpolate(h, scale_factor=2.0, mode="bilinear", align_corners=False)
            h = layer(torch.cat([h, skips.pop()], dim=1))
        return h

    def features(self, x: torch.Tensor) -> torch.Tensor:
        """Everything before :attr:`last` (the exporter splits that convolution per output)."""
        h = self.trunk(x)
        if self.cfg.stem == 1:
            return h
        if self.cfg.head_stride > 1:
            h = self.pointwise(self.head[0], self.head_low(h))
            up = self.cfg.stem // self.cfg.head_stride
            if up > 1:
                h = F.interpolate(h, scale_factor=float(up), mode="bilinear", align_corners=False)
            return self.head[1](h + self.head_x(x))
        # head[0] is a 1x1 conv on cat(upsample(h), x). A 1x1 conv commutes with bilinear
        # upsampling, so its h part runs at low resolution before the upsampling and its x part
        # at full resolution, summed: the same function without a full-resolution concat
        # (the int8 graph's most expensive node) and with the upsampling on skip_hidden channels.
        conv, c = self.head[0], self.head_low[0].out_channels
        h = F.conv2d(self.head_low(h), conv.weight[:, :c], conv.bias)
        h = F.interpolate(h, scale_factor=float(self.cfg.stem), mode="bilinear", align_corners=False)
        return self.head[1](h + F.conv2d(x, conv.weight[:, c:]))

    def pointwise(self, conv: nn.Conv2d, h: torch.Tensor, weight: torch.Tensor | None = None,
                  bias: torch.Tensor | None = None) -> torch.Tensor:
        """The 1x1 convolution ``conv`` (or ``weight``/``bias`` in its place) applied to ``h``; with
        :attr:`pointwise_matmul` written as a matrix product over the channels, the same numbers.
        The int8 exporter keeps the half-resolution head in float and sets it: onnxruntime moves
        float Convs into its blocked channel layout, and the reorders in and out of it cost more
        than the convolutions themselves; a MatMul stays in the plain layout."""
        w = conv.weight if weight is None else weight
        b = conv.bias if bias is None and weight is None else bias
        if not self.pointwise_matmul:
            return F.conv2d(h, w, b)
        n, c, height, width = h.shape
        y = torch.matmul(w.reshape(w.shape[0], w.shape[1]), h.reshape(n, c, height * width))
        if b is not None:
            y = y + b.reshape(1, -1, 1)
        return y.reshape(n, w.shape[0], height, width)

    def to_full(self, out: torch.Tensor) -> torch.Tensor:
        """:attr:`last`'s output at the input's resolution (upsampled with ``head_stride`` 2)."""
        if self.cfg.head_stride == 1:
            return out
        return F.interpolate(out, scale_factor=float(self.cfg.head_stride), mode="bilinear", align_corners=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.forward_parts(x)[0]

    def forward_parts(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """``(output, residual)``: the output of :meth:`forward` and, with ``rgb_skip``, the RGB the
        network adds over the texture's colour, before the mask multiplies it (None without
        ``rgb_skip``). Training penalises it (``TrainConfig.w_residual``)."""
        out = self.to_full(self.last(self.features(x)))
        residual = None
        if self.cfg.rgb_skip:
            residual = out[:, :3]
            out = torch.cat([residual + self.colour(x).to(out.dtype), out[:, 3:]], dim=1)
        if self.cfg.premultiply:
            logit = out[:, 3:]
            out = torch.cat([out[:, :3] * torch.sigmoid(logit), logit], dim=1)
        return out, residual


def count_parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())
