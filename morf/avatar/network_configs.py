"""The sizes of the avatar's networks (:class:`RendererConfig`, :class:`WarpConfig`), torch-free:
a training config, the preset registry and every ``morf`` command line read them without
importing the networks (``morf.avatar.renderer``, ``morf.avatar.warp``), which re-export them."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RendererConfig:
    """Size of the U-Net renderer."""

    in_channels: int = 16  # neural texture channels
    width: int = 16  # channels after the stem (first level)
    depth: int = 4  # number of down-sampling levels
    max_width: int = 256  # channel cap per level
    stem: int = 2  # 1: full-resolution U-Net; 2 or 4: strided stem + full-resolution skip
    skip_hidden: int = 16  # hidden channels of the full-resolution head (stem > 1)
    premultiply: bool = True  # RGB = linear head x sigmoid(mask logit): black wherever the mask is off
    # RGB = the input's channels 0-2 (the texture's colour channels) + the head's output, whose RGB
    # weights start at zero: at step 0 the avatar shows the projected colours (the no-learning
    # floor) and the network only learns a residual over them (Deferred Neural Rendering keeps
    # three texture channels RGB the same way). False: the head alone makes the colour.
    rgb_skip: bool = False
    # With ``rgb_skip``: pixels off the body mesh take the colour of the nearest covered pixels
    # (a push-pull fill over this many 2x levels, more on images over 256 px so that it reaches as
    # far across the person at any size; 0: no fill)
    # before the residual is added, so where the real silhouette reaches past the fitted body the
    # skip offers the neighbouring colour, not black.
    fill_levels: int = 4
    # 1: the head's 1x1 convolutions run at the input's resolution. 2: at half of it, a quarter of
    # the pixels (with a stem of 4 at 640x640 the full-resolution head was a third of the int8
    # graph's time); only its 4 outputs are upsampled to full resolution.
    head_stride: int = 1

    @property
    def multiple(self) -> int:
        """Image sides must be multiples of this."""
        return self.stem * 2 ** self.depth


@dataclass(frozen=True)
class WarpConfig:
    """Sizes of the warp networks."""

    pose_dim: int = 103 * 3  # flattened body rotvecs without the root (see pose_features)
    latent_dim: int = 32  # per-frame latent z
    style_dim: int = 64  # style vector w
    mlp_layers: int = 3  # depth of W
    fourier_freqs: int = 6  # positional encoding: sin/cos of 2^k * pi * (x, y), k < fourier_freqs
    base_resolution: int = 64  # resolution of the encoding and of the predicted offsets
    width: int = 32  # channels of E's first level (doubles per level, capped at 4x)
    levels: int = 3  # down-sampling levels in E (and up-sampling in F)
