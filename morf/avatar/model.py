"""The full avatar during training: neural texture + optional warp field + renderer.

Rendering a training frame: ``features = sample_texture(warp_texture(T, W(p, z)), uv, mask)``,
``renderer(features) -> RGB + mask logit``. Without a warp field (the StylePeople and ANR
baselines) the texture is sampled directly. :func:`bake_texture` applies the warp for the
neutral A-pose and the mean latent once, giving the static texture used at inference.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from morf.avatar.renderer import RendererConfig, UNetRenderer
from morf.avatar.texture import NeuralTexture, sample_texture
from morf.avatar.warp import WarpConfig, WarpField, warp_texture


@dataclass(frozen=True)
class AvatarOutput:
    """One rendered batch.

    Fields:
        rgb: (B, 3, H, W) premultiplied linear RGB (about [0, 1]; not clamped, the loss sees it raw).
        mask_logit: (B, 1, H, W) person mask logits.
        features: (B, C, H, W) the neural rasterization fed to the renderer.
        offsets: (B, 2, Ht, Wt) texture offsets, or None without warping.
        residual: (B, 3, H, W) the RGB the renderer adds over the texture's colour channels
            (``RendererConfig.rgb_skip``), before the mask multiplies it; None without them.
    """

    rgb: torch.Tensor
    mask_logit: torch.Tensor
    features: torch.Tensor
    offsets: torch.Tensor | None
    residual: torch.Tensor | None = None

    @property
    def mask(self) -> torch.Tensor:
        return torch.sigmoid(self.mask_logit)


class AvatarModel(nn.Module):
    """Texture, warp (None for baselines) and renderer, trained jointly."""

    def __init__(self, texture_init: torch.Tensor, renderer_cfg: RendererConfig, warp_cfg: WarpConfig | None,
                 num_frames: int):
        super().__init__()
        C, H, W = texture_init.shape
        self.texture = NeuralTexture(C, H, W, texture_init)
        self.warp = WarpField(warp_cfg, num_frames) if warp_cfg is not None else None
        self.renderer = UNetRenderer(renderer_cfg)

    @property
    def texture_size(self) -> tuple[int, int]:
        return tuple(self.texture.texture.shape[-2:])

    def frame_texture(self, pose: torch.Tensor | None, frame_index: torch.Tensor | None):
        """(B, C, Ht, Wt) warped textures and their offsets, or the shared texture and None."""
        if self.warp is None or pose is None:
            return self.texture.texture, None
        offsets = self.warp(pose, frame_index, self.texture_size)
        return warp_texture(self.texture.texture, offsets), offsets

    def forward(self, uv: torch.Tensor, uv_mask: torch.Tensor, pose: torch.Tensor | None = None,
                frame_index: torch.Tensor | None = None, bf16: bool = False, warp_scale: float = 1.0) -> AvatarOutput:
        """Render training frames.

        The warp is applied at the pixels' UVs (``sample_texture(..., offsets=)``) rather than by
        resampling the whole texture per frame: the same warped lookup, but it never builds
        (B, C, Ht, Wt) warped textures (at 256^2 that and its gradient were a large share of a step).

        Args:
            uv: (B, H, W, 2) rasterized UVs; uv_mask: (B, H, W) mesh coverage;
            pose: (B, pose_dim) pose features (see :func:`morf.avatar.warp.pose_features`);
            frame_index: (B,) long indices into the warp's latent table;
            bf16: run the renderer under bfloat16 autocast (outputs are returned as float32);
            warp_scale: factor on the offsets (the warp fade of training; 1: as the warp made them).
        """
        offsets = None
        if self.warp is not None and pose is not None:
            offsets = self.warp(pose, frame_index, self.texture_size)
            if warp_scale != 1.0:
                offsets = offsets * warp_scale
        feats = sample_texture(self.texture.texture, uv, uv_mask, offsets)
        x = feats
        if self.renderer.stem[0].weight.is_contiguous(memory_format=torch.channels_last):
            x = feats.contiguous(memory_format=torch.channels_last)
        with torch.autocast(feats.device.type, dtype=torch.bfloat16, enabled=bf16):
            out, residual = self.renderer.forward_parts(x)
        out = out.float().contiguous()
        return AvatarOutput(out[:, :3], out[:, 3:], feats, offsets, residual)

    @torch.no_grad()
    def bake(self) -> torch.Tensor:
        """(C, Ht, Wt) the static texture used at inference (see :func:`bake_texture`)."""
        return bake_texture(self.texture.texture, self.warp)


def bake_texture(texture: torch.Tensor, warp: WarpField | None) -> torch.Tensor:
    """Apply the warp of the neutral A-pose (zero rotvecs) and the mean latent once.

    Args:
        texture: (C, Ht, Wt); warp: the trained warp field or None (returns a copy of ``texture``).
    Returns:
        (C, Ht, Wt) baked texture.
    """
    if warp is None:
        return texture.detach().clone()
    pose = torch.zeros(1, warp.cfg.pose_dim, device=texture.device, dtype=texture.dtype)
    offsets = warp.offsets(pose, warp.mean_latent(), tuple(texture.shape[-2:]))
    return warp_texture(texture, offsets)[0].detach()


def render_with_texture(renderer: nn.Module, texture: torch.Tensor, uv: torch.Tensor,
                        uv_mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Inference path: (C, Ht, Wt) baked texture + (B, H, W, 2) UVs -> RGB (B, 3, H, W) premultiplied and
    clamped to [0, 1], mask probability (B, 1, H, W)."""
    out = renderer(sample_texture(texture, uv, uv_mask))
    return out[:, :3].clamp(0, 1), torch.sigmoid(out[:, 3:])
