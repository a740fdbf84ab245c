"""Neural texture warping (MoRF Sec. 3.2): a per-frame offset field in texture space.

``W(p, z) -> w`` maps the frame's normalised pose vector and learned latent to a style vector;
a constant Fourier positional encoding of texture coordinates goes through a convolutional encoder
``E`` whose AdaIN layers are conditioned on ``w`` and a decoder ``F`` that outputs a 2-channel
offset field at reduced resolution, upsampled bilinearly to the texture. The texture is then
resampled at ``texel + offset``.

Offsets are in ``grid_sample`` units of the texture: x right, y DOWN (texture rows), both spanning
[-1, 1] across the texture, so an offset of ``2 / Wt`` moves one texel. The last decoder layer
starts at zero: a fresh warp is the identity.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from morf.avatar.network_configs import WarpConfig  # noqa: F401  (the warp networks' size, torch-free)


def fourier_encoding(height: int, width: int, num_freqs: int) -> torch.Tensor:
    """(2 + 4 * num_freqs, H, W) constant positional encoding of texel centres in [-1, 1]."""
    y = (torch.arange(height, dtype=torch.float32) + 0.5) / height * 2 - 1
    x = (torch.arange(width, dtype=torch.float32) + 0.5) / width * 2 - 1
    yy, xx = torch.meshgrid(y, x, indexing="ij")
    feats = [xx, yy]
    for k in range(num_freqs):
        s = (2 ** k) * math.pi
        feats += [torch.sin(s * xx), torch.cos(s * xx), torch.sin(s * yy), torch.cos(s * yy)]
    return torch.stack(feats)


class AdaINConv(nn.Module):
    """conv -> instance norm -> per-channel scale/shift from the style -> LeakyReLU."""

    def __init__(self, cin: int, cout: int, style_dim: int, stride: int = 1):
        super().__init__()
        self.conv = nn.Conv2d(cin, cout, 3, stride, 1)
        self.norm = nn.InstanceNorm2d(cout, affine=False)
        self.affine = nn.Linear(style_dim, 2 * cout)
        nn.init.zeros_(self.affine.weight)
        with torch.no_grad():  # start as plain instance norm: scale 1, shift 0
            self.affine.bias.zero_()
            self.affine.bias[:cout] = 1.0

    def forward(self, x: torch.Tensor, w: torch.Tensor) -> torch.Tensor:
        h = self.norm(self.conv(x))
        scale, shift = self.affine(w).chunk(2, dim=1)
        return F.leaky_relu(h * scale[..., None, None] + shift[..., None, None], 0.2)


class WarpField(nn.Module):
    """``W``, ``E`` and ``F`` together: (pose features, latents) -> (B, 2, Ht, Wt) offsets."""

    def __init__(self, cfg: WarpConfig, num_frames: int):
        super().__init__()
        self.cfg = cfg
        self.latents = nn.Embedding(num_frames, cfg.latent_dim)
        nn.init.normal_(self.latents.weight, std=0.01)
        layers, d = [], cfg.pose_dim + cfg.latent_dim
        for _ in range(cfg.mlp_layers):
            layers += [nn.Linear(d, cfg.style_dim), nn.LeakyReLU(0.2)]
            d = cfg.style_dim
        self.mlp = nn.Sequential(*layers)
        self.register_buffer("encoding", fourier_encoding(cfg.base_resolution, cfg.base_resolution, cfg.fourier_freqs),
                             persistent=False)
        chans = [min(cfg.width * 2 ** i, cfg.width * 4) for i in range(cfg.levels + 1)]
        self.enc_in = AdaINConv(self.encoding.shape[0], chans[0], cfg.style_dim)
        self.down = nn.ModuleList(AdaINConv(chans[i], chans[i + 1], cfg.style_dim, stride=2) for i in range(cfg.levels))
        self.up = nn.ModuleList(
            nn.Sequential(nn.Conv2d(chans[i + 1] + chans[i], chans[i], 3, 1, 1), nn.LeakyReLU(0.2))
            for i in reversed(range(cfg.levels)))
        self.out = nn.Conv2d(chans[0], 2, 3, 1, 1)
        nn.init.zeros_(self.out.weight)
        nn.init.zeros_(self.out.bias)
        # Pose normalisation (set from the training frames; saved with the model).
        self.register_buffer("pose_mean", torch.zeros(cfg.pose_dim))
        self.register_buffer("pose_std", torch.ones(cfg.pose_dim))

    def set_pose_statistics(self, poses: torch.Tensor) -> None:
        """poses: (N, pose_dim) raw pose features of the training frames."""
        self.pose_mean.copy_(poses.mean(0))
        self.pose_std.copy_(poses.std(0, unbiased=False).clamp_min(0.05))

    def style(self, pose: torch.Tensor, latent: torch.Tensor) -> torch.Tensor:
        """(B, pose_dim) raw pose features, (B, latent_dim) -> (B, style_dim)."""
        p = (pose - self.pose_mean) / self.pose_std
        return self.mlp(torch.cat([p, latent], dim=1))

    def offsets(self, pose: torch.Tensor, latent: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
        """(B, 2, Ht, Wt) texture offsets (grid units, x right, y down) for ``size`` = (Ht, Wt)."""
        w = self.style(pose, latent)
        x = self.encoding.unsqueeze(0).expand(w.shape[0], -1, -1, -1)
        skips = [self.enc_in(x, w)]
        for layer in self.down:
            skips.append(layer(skips[-1], w))
        h = skips.pop()
        for layer in self.up:
            s = skips.pop()
            h = F.interpolate(h, size=s.shape[-2:], mode="bilinear", align_corners=False)
            h = layer(torch.cat([h, s], dim=1))
        off = self.out(h)
        if tuple(off.shape[-2:]) != tuple(size):
            off = F.interpolate(off, size=size, mode="bilinear", align_corners=False)
        return off

    def forward(self, pose: torch.Tensor, frame_index: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
        """Offsets for training frames given their indices (B,) into the latent table."""
        return self.offsets(pose, self.latents(frame_index), size)

    def mean_latent(self) -> torch.Tensor:
        """(1, latent_dim) the average latent over the training frames (used for baking)."""
        return self.latents.weight.mean(0, keepdim=True)


def pose_features(rotvecs: torch.Tensor) -> torch.Tensor:
    """(B, J, 3) body rotvecs -> (B, (J-1)*3) pose vector without the root.

    The root rotation says where the person faces, not how clothes sit on the body; leaving it
    out keeps the warp a function of body pose (plus the frame latent), so the neutral-pose bake
    is not biased towards whichever view dominated training.
    """
    return rotvecs[:, 1:].reshape(rotvecs.shape[0], -1)


def warp_texture(texture: torch.Tensor, offsets: torch.Tensor) -> torch.Tensor:
    """Resample a texture at ``texel centre + offset``.

    Args:
        texture: (C, Ht, Wt) or (B, C, Ht, Wt); offsets: (B, 2, Ht, Wt) grid units (x right, y down).
    Returns:
        (B, C, Ht, Wt) warped textures; zero offsets return the texture exactly.
    """
    B, _, H, W = offsets.shape
    if texture.dim() == 3:
        texture = texture.unsqueeze(0).expand(B, -1, -1, -1)
    y = (torch.arange(H, device=offsets.device, dtype=offsets.dtype) + 0.5) / H * 2 - 1
    x = (torch.arange(W, device=offsets.device, dtype=offsets.dtype) + 0.5) / W * 2 - 1
    yy, xx = torch.meshgrid(y, x, indexing="ij")
    grid = torch.stack([xx, yy], dim=-1).unsqueeze(0) + offsets.permute(0, 2, 3, 1)
    return F.grid_sample(texture, grid, mode="bilinear", padding_mode="border", align_corners=False)


def offsets_to_rgb(offsets: torch.Tensor, max_magnitude: float | None = None) -> torch.Tensor:
    """(2, H, W) offsets -> (H, W, 3) uint8 colour coding: hue = direction, value = magnitude."""
    import numpy as np
    import cv2

    o = offsets.detach().float().cpu().numpy()
    mag = np.sqrt((o ** 2).sum(0))
    ang = np.arctan2(o[1], o[0])
    scale = max_magnitude or max(float(mag.max()), 1e-6)
    hsv = np.stack([(ang + np.pi) / (2 * np.pi) * 179, np.full_like(mag, 255), np.clip(mag / scale, 0, 1) * 255], -1)
    return torch.from_numpy(cv2.cvtColor(hsv.astype(np.uint8), cv2.COLOR_HSV2RGB))
