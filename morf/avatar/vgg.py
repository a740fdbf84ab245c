"""VGG-16 features for the perceptual loss and for LPIPS (:mod:`morf.avatar.lpips`, which reads
them up to relu5_3: ``load_vgg16(path, max_layer=29)``), loaded from a torchvision-format state
dict on disk.

No weights are ever downloaded. Point ``--vgg PATH`` or ``$MORF_VGG16_WEIGHTS`` at a file such as
torchvision's ``vgg16-397923af.pth`` (keys ``features.N.weight`` / ``features.N.bias``; the
classifier keys are ignored). It is read with ``torch.load(weights_only=True)``.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

from morf.errors import InputError
from morf.io.torch_files import load_torch_file

ENV_VAR = "MORF_VGG16_WEIGHTS"
# torchvision's vgg16 "features": numbers are conv widths, "M" a 2x2 max-pool.
_CFG = [64, 64, "M", 128, 128, "M", 256, 256, 256, "M", 512, 512, 512, "M", 512, 512, 512, "M"]
# Indices into ``features`` after which activations are taken: relu1_2, relu2_2, relu3_3, relu4_3, relu5_3.
FEATURE_LAYERS = (3, 8, 15, 22, 29)
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


class VGG16Features(nn.Module):
    """The convolutional part of VGG-16 with torchvision's module indices (so state dicts load)."""

    def __init__(self, max_layer: int = 29):
        super().__init__()
        layers: list[nn.Module] = []
        cin = 3
        for v in _CFG:
            if v == "M":
                layers.append(nn.MaxPool2d(2, 2))
            else:
                layers += [nn.Conv2d(cin, v, 3, padding=1), nn.ReLU(inplace=False)]
                cin = v
        self.features = nn.Sequential(*layers[:max_layer + 1])
        self.register_buffer("mean", torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(IMAGENET_STD).view(1, 3, 1, 1), persistent=False)

    def forward(self, rgb: torch.Tensor, layers=FEATURE_LAYERS) -> list[torch.Tensor]:
        """(B, 3, H, W) RGB in [0, 1] -> activations after each index in ``layers``."""
        return self.activations((rgb - self.mean) / self.std, layers)

    def activations(self, x: torch.Tensor, layers=FEATURE_LAYERS) -> list[torch.Tensor]:
        """Activations after each index in ``layers`` of an input already normalised as the weights
        expect (``forward`` applies the ImageNet mean and std first)."""
        out = []
        for i, m in enumerate(self.features):
            x = m(x)
            if i in layers:
                out.append(x)
            if i >= max(layers):
                break
        return out


def resolve_vgg_path(path: str | os.PathLike | None) -> Path | None:
    """The weights file to use: the explicit path, else ``$MORF_VGG16_WEIGHTS``, else None."""
    p = path or os.environ.get(ENV_VAR)
    return Path(p) if p else None


def read_state_dict(path: Path, what: str) -> dict:
    """The state dict in ``path`` (a ``{"state_dict": ...}`` wrapper unwrapped; {} when the file
    holds no dict), read with ``torch.load(weights_only=True)``, which unpickles tensors and plain
    containers only. A missing or unreadable file is an InputError naming ``what``."""
    state = load_torch_file(path, what=what, missing=InputError,
                            use=f"use the {what} as published (a state dict of tensors)")
    if isinstance(state, dict) and "state_dict" in state and isinstance(state["state_dict"], dict):
        state = state["state_dict"]
    return state if isinstance(state, dict) else {}


def load_vgg16(path: str | os.PathLike, max_layer: int = 22) -> VGG16Features:
    """A frozen :class:`VGG16Features` (up to ``max_layer``) from a torchvision-format state dict."""
    path = Path(path)
    state = read_state_dict(path, "VGG-16 weights")
    net = VGG16Features(max_layer)
    wanted = {k: v for k, v in state.items() if k.startswith("features.")}
    own = net.state_dict()
    missing = [k for k in own if k not in wanted]
    if missing:
        raise InputError(f"{path} is not a torchvision VGG-16 state dict (missing {missing[0]})")
    for k in own:
        if tuple(wanted[k].shape) != tuple(own[k].shape):
            raise InputError(f"{path}: {k} has shape {tuple(wanted[k].shape)}, expected {tuple(own[k].shape)}")
    net.load_state_dict({k: wanted[k] for k in own})
    net.eval().requires_grad_(False)
    return net


class PerceptualLoss(nn.Module):
    """Mean L1 distance between VGG-16 activations (relu1_2 ... relu4_3) of two images."""

    def __init__(self, vgg: VGG16Features, layers=FEATURE_LAYERS[:4]):
        super().__init__()
        self.vgg = vgg
        self.layers = layers

    def forward(self, pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        fp = self.vgg(pred, self.layers)
        with torch.no_grad():
            ft = self.vgg(target, self.layers)
        return sum(F.l1_loss(a, b) for a, b in zip(fp, ft)) / len(fp)
