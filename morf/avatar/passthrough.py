"""The renderer of the RGB floor (``morf train --method rgb``): no network, the sampled texture
is the image.

Its texture has 4 channels: RGB projected from the training frames, and a constant 1.
``sample_texture`` zeroes every pixel the mesh does not cover, so after sampling the fourth
channel is exactly the mesh coverage (0 or 1). The output follows the U-Net renderer's contract
(``(B, 4, H, W)``: RGB premultiplied by the mask, then a mask logit): RGB is the sampled colour
(already zero off the mesh) and the logit is ``(coverage - 0.5) * gain``, so the mask
probability is 1 on the mesh (``sigmoid(20)`` rounds to 1 in float32) and 2e-9 off it.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn


@dataclass(frozen=True)
class PassthroughConfig:
    """Settings of :class:`PassthroughRenderer` (stored in ``avatar.pt`` like a U-Net's)."""

    in_channels: int = 4  # RGB + coverage
    gain: float = 40.0  # mask logit per unit of coverage around 0.5

    @property
    def multiple(self) -> int:
        """Image sides must be multiples of this (any size renders)."""
        return 1


class PassthroughRenderer(nn.Module):
    """(B, 4, H, W) sampled RGB + coverage -> (B, 4, H, W) premultiplied RGB + mask logit."""

    kind = "passthrough"

    def __init__(self, cfg: PassthroughConfig = PassthroughConfig()):
        super().__init__()
        if cfg.in_channels != 4:
            raise ValueError("the passthrough renderer takes RGB + coverage (4 channels)")
        self.cfg = cfg

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        coverage = x[:, 3:4]
        return torch.cat([x[:, :3], (coverage - 0.5) * self.cfg.gain], dim=1)
