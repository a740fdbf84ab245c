"""The training objective (MoRF Sec. 4.3): generator and discriminator losses for one batch."""

from __future__ import annotations

import torch

import torch.nn.functional as F

from morf.avatar.losses import (dice_loss, feature_matching_loss, gan_discriminator_loss, gan_generator_loss,
                                l1_loss, offset_l2, ssim_loss, tv_loss)
from morf.avatar.model import AvatarModel, AvatarOutput
from morf.avatar.warp import pose_features
from morf.train.config import TrainConfig
from morf.train.frames import Batch


def render_batch(model: AvatarModel, batch: Batch, bf16: bool = False, warp_scale: float = 1.0) -> AvatarOutput:
    """Render a training batch; ``warp_scale`` multiplies the warp's offsets (0: no warp at all)."""
    pose = pose_features(batch.rotvecs) if model.warp is not None and warp_scale > 0 else None
    return model(batch.uv, batch.uv_mask, pose, batch.index, bf16=bf16, warp_scale=warp_scale)


def run_discriminator(disc, x: torch.Tensor, bf16: bool = False) -> list[list[torch.Tensor]]:
    """``disc(x)`` (optionally under bfloat16 autocast, channels-last if D is); features as float32."""
    if next(disc.parameters()).is_contiguous(memory_format=torch.channels_last) and x.dim() == 4:
        x = x.contiguous(memory_format=torch.channels_last)
    with torch.autocast(x.device.type, dtype=torch.bfloat16, enabled=bf16):
        feats = disc(x)
    return [[f.float() for f in scale] for scale in feats]


def composited(out: AvatarOutput, target: torch.Tensor, mask: torch.Tensor,
               colour: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Render and premultiplied target over the same random colour, one per image (``rgb + (1 -
    mask) * colour``, the player's composite): colour and mask are judged together, so an
    uncertain edge pixel costs the same whichever way it is wrong.

    ``colour``: (B, 3) or (B, 3, 1, 1) colours in [0, 1] (the trainer draws them from the step's
    own seed, so a resumed run sees the same ones); None draws them from torch's global generator.
    """
    if colour is None:
        colour = torch.rand(target.shape[0], 3, 1, 1, device=target.device, dtype=target.dtype)
    colour = colour.to(device=target.device, dtype=target.dtype).reshape(target.shape[0], 3, 1, 1)
    return out.rgb + (1 - out.mask) * colour, target + (1 - mask) * colour


def outline_weight(mask: torch.Tensor, inset: int) -> torch.Tensor | None:
    """(B, 1, H, W) 0 on the pixels of ``mask`` (B, 1, H, W) within ``inset`` pixels of its outline
    (the mask less its erosion by a (2 inset + 1) square), 1 elsewhere; None for ``inset`` 0."""
    if inset <= 0:
        return None
    eroded = -F.max_pool2d(-mask, 2 * inset + 1, 1, inset)
    return 1 - (mask - eroded).clamp(0, 1)


def generator_losses(cfg: TrainConfig, out: AvatarOutput, batch: Batch, disc=None, perceptual=None,
                     gan_on: bool = False, bf16: bool | None = None,
                     backdrop: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
    """Unweighted loss terms of the generator side (texture, warp, renderer).

    Keys: l1, dice, tv_rgb, and when applicable ssim, mask_bce, residual, perceptual, warp_l2, warp_tv, gan,
    feature_matching.
    The RGB target is the frame premultiplied by its person mask (the renderer's convention); with
    ``cfg.loss_background == "random"`` the image terms compare render and frame composited over
    one random colour per image (:func:`composited`; ``backdrop``: those colours, (B, 3)).
    """
    bf16 = cfg.bf16 if bf16 is None else bf16
    target = batch.image * batch.mask
    image, image_target = out.rgb, target
    if cfg.loss_background == "random":
        image, image_target = composited(out, target, batch.mask, backdrop)
    inner = outline_weight(batch.mask, cfg.loss_edge_inset)  # the outline's mixed pixels left out
    L = {"l1": l1_loss(image, image_target, inner), "dice": dice_loss(out.mask, batch.mask),
         "tv_rgb": tv_loss(out.rgb)}
    if cfg.w_ssim > 0:  # around the person: the real mask grown by the SSIM window's radius
        near = F.max_pool2d(batch.mask, 11, 1, 5)
        L["ssim"] = ssim_loss(image, image_target, near if inner is None else near * inner)
    if cfg.w_mask_bce > 0:  # a gradient that does not vanish when the mask's sigmoid saturates
        L["mask_bce"] = F.binary_cross_entropy_with_logits(out.mask_logit.float(), batch.mask)
    if cfg.w_residual > 0 and out.residual is not None:
        L["residual"] = (out.residual.float() * out.mask).abs().mean()  # as far as it shows in the image
    if perceptual is not None:
        L["perceptual"] = perceptual(image, image_target)
    if out.offsets is not None:
        L["warp_l2"] = offset_l2(out.offsets)
        L["warp_tv"] = tv_loss(out.offsets)
    if disc is not None and gan_on:
        fake = run_discriminator(disc, torch.cat([out.rgb, out.mask], dim=1), bf16)
        L["gan"] = gan_generator_loss([f[-1] for f in fake])
        if perceptual is None and cfg.w_feature_matching > 0:  # no VGG weights: feature matching stands in
            with torch.no_grad():
                real = run_discriminator(disc, torch.cat([target, batch.mask], dim=1), bf16)
            L["feature_matching"] = feature_matching_loss(real, fake)
    return L


WEIGHTS = {"l1": "w_l1", "ssim": "w_ssim", "dice": "w_dice", "tv_rgb": "w_tv_rgb", "perceptual": "w_perceptual",
           "warp_l2": "w_warp_l2", "warp_tv": "w_warp_tv", "gan": "w_gan", "feature_matching": "w_feature_matching",
           "residual": "w_residual", "mask_bce": "w_mask_bce"}


def weighted_total(cfg: TrainConfig, losses: dict[str, torch.Tensor]) -> torch.Tensor:
    return sum(getattr(cfg, WEIGHTS[k]) * v for k, v in losses.items())


def discriminator_loss(disc, out: AvatarOutput, batch: Batch, bf16: bool = False) -> torch.Tensor:
    """Non-saturating discriminator loss on real frames vs the (detached) renders."""
    real = run_discriminator(disc, torch.cat([batch.image * batch.mask, batch.mask], dim=1), bf16)
    fake = run_discriminator(disc, torch.cat([out.rgb, out.mask], dim=1).detach(), bf16)
    return gan_discriminator_loss([r[-1] for r in real], [f[-1] for f in fake])
