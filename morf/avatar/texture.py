"""Neural texture and texture sampling.

Convention (tested in tests/avatar/test_texture.py): a texel ``(row, col)`` of a ``(C, Ht, Wt)``
texture covers ``u in [col/Wt, (col+1)/Wt]`` and ``v in [1 - (row+1)/Ht, 1 - row/Ht]`` (v up, row 0 at
the top). ``grid_sample`` with ``align_corners=False`` treats -1/+1 as the outer edges of the border
texels, so the grid is ``x = 2u - 1`` and ``y = 1 - 2v``; a UV at a texel centre returns that texel
exactly.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


def uv_to_grid(uv: torch.Tensor) -> torch.Tensor:
    """(..., 2) mesh UVs (v up) -> (..., 2) ``grid_sample`` coordinates in [-1, 1] (y down)."""
    return torch.stack([uv[..., 0] * 2 - 1, 1 - uv[..., 1] * 2], dim=-1)


def sample_texture(texture: torch.Tensor, uv: torch.Tensor, mask: torch.Tensor | None = None,
                   offsets: torch.Tensor | None = None) -> torch.Tensor:
    """Look a texture up at per-pixel UVs (bilinear), zero outside the mask.

    Args:
        texture: (C, Ht, Wt) shared or (B, C, Ht, Wt) per image.
        uv: (B, H, W, 2) mesh UVs, v up.
        mask: (B, H, W) bool/float, pixels covered by the mesh (None: all).
        offsets: (B, 2, h, w) texture-space warp offsets in grid units (x right, y down; any
            resolution, interpolated bilinearly), or None. Looking up ``texture`` at
            ``uv + offsets(uv)`` equals sampling the warped texture
            :func:`morf.avatar.warp.warp_texture` at ``uv`` (up to interpolation order) without
            building a (B, C, Ht, Wt) warped texture and its dense gradient.
    Returns:
        (B, C, H, W) sampled features.
    """
    B = uv.shape[0]
    if texture.dim() == 3:
        texture = texture.unsqueeze(0).expand(B, -1, -1, -1)
    grid = uv_to_grid(uv).to(texture.dtype)
    if offsets is not None:
        d = F.grid_sample(offsets.to(texture.dtype), grid, mode="bilinear", padding_mode="border", align_corners=False)
        grid = grid + d.permute(0, 2, 3, 1)
    out = F.grid_sample(texture, grid, mode="bilinear", padding_mode="border", align_corners=False)
    if mask is not None:
        out = out * mask.to(out.dtype).unsqueeze(1)
    return out


def texel_centre_uvs(height: int, width: int, device=None) -> torch.Tensor:
    """(Ht, Wt, 2) the UV of every texel centre (v up), handy for tests and texture-space maps."""
    v = 1 - (torch.arange(height, device=device, dtype=torch.float32) + 0.5) / height
    u = (torch.arange(width, device=device, dtype=torch.float32) + 0.5) / width
    vv, uu = torch.meshgrid(v, u, indexing="ij")
    return torch.stack([uu, vv], dim=-1)


class NeuralTexture(nn.Module):
    """A learned (C, Ht, Wt) texture, usually initialised with spectral coordinates."""

    def __init__(self, channels: int, height: int, width: int, init: torch.Tensor | None = None):
        super().__init__()
        if init is None:
            init = torch.randn(channels, height, width) * 0.1
        if init.shape != (channels, height, width):
            raise ValueError(f"texture init must be {(channels, height, width)}, got {tuple(init.shape)}")
        self.texture = nn.Parameter(init.clone().float())

    def forward(self, uv: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """(B, H, W, 2) UVs -> (B, C, H, W) features."""
        return sample_texture(self.texture, uv, mask)
