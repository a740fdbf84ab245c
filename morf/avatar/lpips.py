"""LPIPS (Zhang et al. 2018, "The Unreasonable Effectiveness of Deep Features as a Perceptual
Metric"): the ``lpips`` package's "vgg" network, version 0.1, computed from weights already on disk.

Nothing is downloaded and the ``lpips`` package is not needed; two files are:

* the linear layers: the ``lpips`` package's ``weights/v0.1/vgg.pth`` (a state dict with keys
  ``lin0.model.1.weight`` ... ``lin4.model.1.weight``, shapes (1, C, 1, 1), C = 64, 128, 256,
  512, 512), from ``--lpips PATH`` or ``$MORF_LPIPS_WEIGHTS``;
* the VGG-16 features: torchvision's ``vgg16-397923af.pth``, read as the perceptual loss reads it
  (:func:`morf.avatar.vgg.load_vgg16`), from ``--vgg PATH`` or ``$MORF_VGG16_WEIGHTS``.

Both are read with ``torch.load(weights_only=True)``.

The distance of two images in [0, 1]: each is scaled to [-1, 1] and through the LPIPS scaling
layer (``(x - shift) / scale``, shift (-0.030, -0.088, -0.188), scale (0.458, 0.448, 0.450));
VGG-16 activations at relu1_2, relu2_2, relu3_3, relu4_3 and relu5_3 are unit-normalised over the
channels (``f / (|f| + 1e-10)``); per level the squared difference of the two goes through the
level's 1x1 convolution (no bias) and is averaged over space; the levels are summed.

Our extension, ``mask``: the spatial average of every level is taken over the mask instead,
area-resized to the level's size (a weighted mean, the weights the share of each cell the mask
covers); with the person mask this is a person-only LPIPS. It is NaN where the mask is empty.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

from morf.avatar.vgg import FEATURE_LAYERS, VGG16Features, load_vgg16, read_state_dict, resolve_vgg_path
from morf.errors import InputError

ENV_VAR = "MORF_LPIPS_WEIGHTS"
LIN_KEYS = tuple(f"lin{i}.model.1.weight" for i in range(5))
LIN_CHANNELS = (64, 128, 256, 512, 512)
SHIFT = (-0.030, -0.088, -0.188)
SCALE = (0.458, 0.448, 0.450)
EPS = 1e-10
MIN_SIDE = 16  # relu5_3 is 1/16 of the input


def check_lin(lin: dict, source: str = "lin") -> list[torch.Tensor]:
    """The five linear-layer weights of ``lin`` (keys :data:`LIN_KEYS`), checked; InputError naming
    ``source`` for a missing key or a wrong shape."""
    out = []
    for key, c in zip(LIN_KEYS, LIN_CHANNELS):
        w = lin.get(key)
        if not isinstance(w, torch.Tensor):
            raise InputError(f"{source} is not an LPIPS v0.1 vgg state dict (missing {key})")
        if tuple(w.shape) != (1, c, 1, 1):
            raise InputError(f"{source}: {key} has shape {tuple(w.shape)}, expected {(1, c, 1, 1)}")
        out.append(w.detach().float())
    return out


class LPIPS(nn.Module):
    """LPIPS v0.1 "vgg" (see the module docstring).

    Args:
        vgg: a :class:`~morf.avatar.vgg.VGG16Features` holding layers up to relu5_3 (index 29).
        lin: the linear layers, keys ``lin0.model.1.weight`` ... ``lin4.model.1.weight``.
    """

    def __init__(self, vgg: VGG16Features, lin: dict):
        super().__init__()
        if len(vgg.features) <= FEATURE_LAYERS[-1]:
            raise ValueError(f"LPIPS needs VGG-16 up to relu5_3 (layer {FEATURE_LAYERS[-1]}); this one stops at "
                             f"layer {len(vgg.features) - 1} (load it with max_layer={FEATURE_LAYERS[-1]})")
        self.vgg = vgg
        self.files: tuple[Path, ...] = ()  # the weights files, when loaded by load_lpips
        for i, w in enumerate(check_lin(lin)):
            self.register_buffer(f"lin{i}", w)
        self.register_buffer("shift", torch.tensor(SHIFT).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("scale", torch.tensor(SCALE).view(1, 3, 1, 1), persistent=False)

    def _features(self, rgb: torch.Tensor) -> list[torch.Tensor]:
        x = (rgb * 2 - 1 - self.shift) / self.scale
        feats = self.vgg.activations(x, FEATURE_LAYERS)
        return [f / (f.pow(2).sum(1, keepdim=True).sqrt() + EPS) for f in feats]

    def maps(self, pred: torch.Tensor, target: torch.Tensor) -> list[torch.Tensor]:
        """Per level, the (B, 1, h, w) map of the linear layer on the squared feature difference
        (before the spatial average); images (B, 3, H, W) in [0, 1], H and W at least 16."""
        if min(pred.shape[-2:]) < MIN_SIDE or pred.shape != target.shape:
            raise ValueError(f"LPIPS compares images of one shape, at least {MIN_SIDE} px a side; got "
                             f"{tuple(pred.shape)} and {tuple(target.shape)}")
        fp, ft = self._features(pred), self._features(target)
        return [F.conv2d((a - b) ** 2, getattr(self, f"lin{i}")) for i, (a, b) in enumerate(zip(fp, ft))]

    @staticmethod
    def reduce(maps: list[torch.Tensor], mask: torch.Tensor | None = None) -> torch.Tensor:
        """(B,) the sum over levels of each map's spatial mean (over ``mask``, (B, 1, H, W) or
        (B, H, W), area-resized to each level, when given)."""
        if mask is None:
            return sum(m.mean((1, 2, 3)) for m in maps)
        mask = (mask.unsqueeze(1) if mask.dim() == 3 else mask).to(maps[0].dtype)
        total = 0
        for m in maps:
            w = F.interpolate(mask, size=m.shape[-2:], mode="area")
            total = total + (m * w).sum((1, 2, 3)) / w.sum((1, 2, 3))
        return total

    def forward(self, pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """(B,) LPIPS of two batches of images in [0, 1]; over ``mask`` (our extension) when given."""
        return self.reduce(self.maps(pred, target), mask)


def resolve_lpips_path(path: str | os.PathLike | None) -> Path | None:
    """The linear-layer weights to use: the explicit path, else ``$MORF_LPIPS_WEIGHTS``, else None."""
    p = path or os.environ.get(ENV_VAR)
    return Path(p) if p else None


def load_lpips(lin_path: str | os.PathLike, vgg_path: str | os.PathLike) -> LPIPS:
    """A frozen :class:`LPIPS` from the ``lpips`` package's ``vgg.pth`` and torchvision's VGG-16
    weights; InputError for a missing or unreadable file, a missing key or a wrong shape. The two
    paths are kept in ``files``."""
    lin_path, vgg_path = Path(lin_path), Path(vgg_path)
    lin = read_state_dict(lin_path, "LPIPS weights")
    check_lin(lin, str(lin_path))
    metric = LPIPS(load_vgg16(vgg_path, max_layer=FEATURE_LAYERS[-1]), lin).eval().requires_grad_(False)
    metric.files = (lin_path, vgg_path)
    return metric


def find_lpips(lin: str | os.PathLike | None = None, vgg: str | os.PathLike | None = None) -> LPIPS | None:
    """LPIPS from the weights named by ``lin`` / ``$MORF_LPIPS_WEIGHTS`` and ``vgg`` /
    ``$MORF_VGG16_WEIGHTS``; None when no LPIPS weights are named (InputError when they are but
    the VGG-16 weights are not)."""
    lin_path = resolve_lpips_path(lin)
    if lin_path is None:
        return None
    vgg_path = resolve_vgg_path(vgg)
    if vgg_path is None:
        raise InputError(f"LPIPS weights {lin_path} given but no VGG-16 weights: pass --vgg PATH or set "
                         "$MORF_VGG16_WEIGHTS (torchvision's vgg16-397923af.pth)")
    return load_lpips(lin_path, vgg_path)
