"""The trainer: owns the avatar, the discriminator and their optimizers; runs one step at a time.

Methods (same code path, MoRF Sec. 5 "Scenario B"):

* ``morf``: neural texture + warp field + renderer, all optimised jointly every step.
* ``stylepeople``: the same without warping (DNR with spectral init and MoRF's losses/renderer).
* ``anr``: StylePeople plus ANR's split optimisation, implemented as alternating updates: on
  every ``anr_texture_every``-th step only the neural texture is updated, on the other steps only
  the renderer. Decoupling the two keeps the renderer from absorbing what the texture should hold
  (ANR's motivation for splitting); the paper's exact schedule is in its supplementary material,
  which is not available here, so this alternation is our reading of it.

Every step draws its frames and crops from ``default_rng((seed, step))``, and the backdrop colours
of ``loss_background="random"`` from ``default_rng((seed, step, 1))``: a resumed run sees the same
data order and colours as an uninterrupted one without storing RNG state. Nothing in a step draws
from torch's global generator (it is seeded once, for the initial weights).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from morf.avatar.discriminator import MultiScaleDiscriminator
from morf.avatar.model import AvatarModel, AvatarOutput
from morf.avatar.warp import pose_features
from morf.machine.features import native_bf16
from morf.train.bf16_check import BF16_TOLERANCE, OFF_NOT_NATIVE, bf16_disagreement
from morf.errors import TrainingDiverged
from morf.train.config import TrainConfig
from morf.train.frames import Batch, FrameSet
from morf.train.objective import discriminator_loss, generator_losses, render_batch, weighted_total


# Share of the head, the left and the right hand among detail crops (morf.train.detail.DETAIL_REGIONS):
# the face is where a viewer looks first, and it holds the most detail per pixel.
DETAIL_SHARE = (0.5, 0.25, 0.25)


def pick_device(name: str = "auto") -> torch.device:
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(name)


class Trainer:
    """Training state for one run. Use :meth:`train_step`; save with :meth:`state_dict`."""

    def __init__(self, cfg: TrainConfig, frames: FrameSet, texture_init: torch.Tensor, device=None, perceptual=None,
                 zoom_frames: FrameSet | None = None, detail_centres: np.ndarray | None = None):
        self.cfg = cfg
        self.frames = frames
        if zoom_frames is not None and not np.array_equal(zoom_frames.frame_ids, frames.frame_ids):
            raise ValueError("the zoomed frames must be the same frames as the training frames")
        self.zoom_frames = zoom_frames  # the same frames at cfg.zoom_resolution (every other step)
        if detail_centres is not None and (zoom_frames is None or detail_centres.shape[:1] != (frames.num_frames,)):
            raise ValueError("detail centres need the zoomed frames and one row per training frame")
        # (N, R, 2) pixel centres of the head and hands in the zoomed frames (cfg.detail_every)
        self.detail_centres = detail_centres if cfg.detail_every else None
        self.device = torch.device(device) if device is not None else pick_device(cfg.device)
        torch.manual_seed(cfg.seed)
        self.model = AvatarModel(texture_init.float(), cfg.renderer, cfg.warp if cfg.method == "morf" else None,
                                 frames.num_frames).to(self.device)
        if self.model.warp is not None:
            poses = pose_features(torch.from_numpy(frames.rotvecs).float()).to(self.device)
            if poses.shape[1] != cfg.warp.pose_dim:
                raise ValueError(f"pose vector has {poses.shape[1]} values, warp expects {cfg.warp.pose_dim}")
            self.model.warp.set_pose_statistics(poses)
        if cfg.colour_frozen:  # Adam leaves a parameter entry whose gradient is always zero where it is
            self.model.texture.texture.register_hook(_without_colour)
        groups = [{"params": [self.model.texture.texture], "lr": cfg.lr_texture, "name": "texture"},
                  {"params": list(self.model.renderer.parameters()), "lr": cfg.lr_renderer, "name": "renderer"}]
        if self.model.warp is not None:
            lat = self.model.warp.latents.weight
            nets = [p for p in self.model.warp.parameters() if p is not lat]
            groups += [{"params": nets, "lr": cfg.lr_warp, "name": "warp"},
                       {"params": [lat], "lr": cfg.lr_latent, "name": "latent"}]
        self.opt = torch.optim.Adam(groups, fused=True)  # fused: one kernel per tensor, not ~10 passes
        self.disc = None
        if cfg.w_gan > 0:
            self.disc = MultiScaleDiscriminator(4, cfg.disc_width, cfg.disc_layers, cfg.disc_scales).to(self.device)
            self.opt_d = torch.optim.Adam(self.disc.parameters(), lr=cfg.lr_discriminator, betas=(0.5, 0.999),
                                          fused=True)
        if cfg.channels_last:
            self.model.renderer.to(memory_format=torch.channels_last)
            if self.disc is not None:
                self.disc.to(memory_format=torch.channels_last)
        for opt in self._optimizers():
            for group in opt.param_groups:
                group["base_lr"] = group["lr"]  # the rate the decay schedule scales (recoveries halve it)
        self.perceptual = perceptual.to(self.device) if perceptual is not None else None
        # the moving average of the avatar's weights (cfg.ema_decay), in model.parameters() order
        self.ema = [p.detach().clone() for p in self.model.parameters()] if cfg.ema_decay > 0 else None
        # bfloat16 autocast where it is fast: on CUDA, or on a CPU that has it natively (cfg.bf16
        # allows it; an emulating CPU would run the step 1.8x slower), and only where this
        # machine's bfloat16 convolutions agree with float32 (bf16_check.py: a wrong kernel
        # trains a renderer that renders wrong in float32). bf16_note says which, for train.log.
        self.bf16 = cfg.bf16 and (self.device.type == "cuda" or native_bf16())
        self.bf16_note = "on" if self.bf16 else OFF_NOT_NATIVE
        if self.bf16:
            err, where = bf16_disagreement([self.model.renderer, self.disc], self.device)
            if err > BF16_TOLERANCE:
                self.bf16 = False
                self.bf16_note = (f"off (this machine's bfloat16 convolution disagrees with float32 at {where}: "
                                  f"relative error {err:.2f})")
        self.step = 0
        self.elapsed_s = 0.0  # training wall time over all sessions of this run
        # Adversarial terms (GAN, feature matching, discriminator updates) held off until the mask
        # has formed: set by the training loop when restarting a run whose mask never formed.
        self.hold_adversarial = False

    # ---- state ----------------------------------------------------------------------------
    def state_dict(self) -> dict:
        d = {"step": self.step, "elapsed_s": self.elapsed_s, "hold_adversarial": self.hold_adversarial,
             "model": self.model.state_dict(), "opt": self.opt.state_dict()}
        if self.disc is not None:
            d["disc"] = self.disc.state_dict()
            d["opt_d"] = self.opt_d.state_dict()
        if self.ema is not None:
            d["ema"] = list(self.ema)
        return d

    def load_state_dict(self, d: dict) -> None:
        self.model.load_state_dict(d["model"])
        self.opt.load_state_dict(d["opt"])
        if self.disc is not None and "disc" in d:
            self.disc.load_state_dict(d["disc"])
            self.opt_d.load_state_dict(d["opt_d"])
        self.step = int(d["step"])
        self.elapsed_s = float(d.get("elapsed_s", 0.0))
        self.hold_adversarial = bool(d.get("hold_adversarial", False))
        if self.ema is not None:  # a checkpoint without an average starts one from its weights
            for e, src in zip(self.ema, d.get("ema") or list(self.model.parameters())):
                e.copy_(src)
        for opt in self._optimizers():
            for group in opt.param_groups:
                group.setdefault("base_lr", group["lr"])  # checkpoints from before the decay schedule

    def _optimizers(self) -> list[torch.optim.Optimizer]:
        return [o for o in (self.opt, getattr(self, "opt_d", None)) if o is not None]

    def scale_learning_rates(self, factor: float) -> None:
        """Multiply every optimizer's learning rates (kept in the optimizer state, so in checkpoints)."""
        for opt in self._optimizers():
            for group in opt.param_groups:
                group["base_lr"] *= factor
                group["lr"] *= factor

    def _apply_schedule(self) -> None:
        factor = self.cfg.lr_factor(self.step)
        for opt in self._optimizers():
            for group in opt.param_groups:
                group["lr"] = group["base_lr"] * factor

    def _update_ema(self) -> None:
        if self.ema is not None:
            decay = min(self.cfg.ema_decay, (1 + self.step) / (10 + self.step))
            with torch.no_grad():
                torch._foreach_lerp_(self.ema, [p.detach() for p in self.model.parameters()], 1.0 - decay)

    def use_averaged_weights(self) -> bool:
        """Load the moving average into the model (for baking and export); False when averaging is off."""
        if self.ema is None:
            return False
        with torch.no_grad():
            for p, e in zip(self.model.parameters(), self.ema):
                p.copy_(e)
        return True

    def parameters_finite(self) -> bool:
        return all(bool(torch.isfinite(p).all()) for p in self.model.parameters())

    # ---- one step -------------------------------------------------------------------------
    def next_batch(self) -> Batch:
        rng = np.random.default_rng([self.cfg.seed, self.step])
        N, B = self.frames.num_frames, self.cfg.batch_size
        idx = rng.choice(N, size=B, replace=N < B)
        if self.detail_centres is not None and self.step % self.cfg.detail_every == self.cfg.detail_every - 1:
            return self._detail_batch(idx, rng)
        if self.zoom_frames is not None and self.step % 2 == 1:
            return self.zoom_frames.batch(idx, self.cfg.crop or self.cfg.resolution, rng, self.device)
        return self.frames.batch(idx, self.cfg.crop, rng, self.device)

    def _detail_batch(self, idx: np.ndarray, rng: np.random.Generator) -> Batch:
        """Crops of the zoomed frames centred on the head (half the images) or a hand."""
        from morf.train.detail import crop_origins

        crop = self.cfg.crop or self.cfg.resolution
        region = rng.choice(len(DETAIL_SHARE), size=len(idx), p=DETAIL_SHARE)
        centres = self.detail_centres[idx, region]
        origins = crop_origins(centres, crop, self.zoom_frames.resolution, rng)
        return self.zoom_frames.batch(idx, crop, rng, self.device, origins=origins)

    def backdrop(self) -> torch.Tensor | None:
        """(B, 3) the backdrop colours of this step's images (``loss_background="random"``), else None."""
        if self.cfg.loss_background != "random":
            return None
        rng = np.random.default_rng([self.cfg.seed, self.step, 1])
        return torch.from_numpy(rng.random((self.cfg.batch_size, 3), dtype=np.float32)).to(self.device)

    def train_step(self) -> tuple[dict[str, float], AvatarOutput, Batch]:
        """One optimisation step. Raises :class:`TrainingDiverged` on NaN/inf (nothing is updated then)."""
        cfg = self.cfg
        batch = self.next_batch()
        self._apply_schedule()
        gan_on = self.disc is not None and self.step >= cfg.gan_start and not self.hold_adversarial
        self.model.train()
        out = render_batch(self.model, batch, self.bf16, cfg.warp_scale(self.step))
        losses = generator_losses(cfg, out, batch, self.disc, self.perceptual, gan_on, self.bf16, self.backdrop())
        total = weighted_total(cfg, losses)
        if not torch.isfinite(total):
            bad = [k for k, v in losses.items() if not torch.isfinite(v)]
            raise TrainingDiverged(f"training diverged at step {self.step}: loss {', '.join(bad) or 'total'} is not finite")
        self.opt.zero_grad(set_to_none=True)
        total.backward()
        if cfg.method == "anr":
            texture_phase = self.step % cfg.anr_texture_every == 0
            for g in self.opt.param_groups:
                if (g["name"] == "texture") != texture_phase:
                    for p in g["params"]:
                        p.grad = None  # Adam skips parameters without a gradient
        params = [p for g in self.opt.param_groups for p in g["params"] if p.grad is not None]
        gnorm = torch.nn.utils.clip_grad_norm_(params, float("inf"))
        if not torch.isfinite(gnorm):
            raise TrainingDiverged(f"training diverged at step {self.step}: gradient is not finite")
        self.opt.step()
        if gan_on:
            self.opt_d.zero_grad(set_to_none=True)
            ld = discriminator_loss(self.disc, out, batch, self.bf16)
            if torch.isfinite(ld):
                ld.backward()
                self.opt_d.step()
            losses["disc"] = ld
        if not self.parameters_finite():
            raise TrainingDiverged(f"training diverged at step {self.step}: parameters became non-finite")
        self._update_ema()
        self.step += 1
        values = {k: float(v.detach()) for k, v in losses.items()}
        values["total"] = float(total.detach())
        return values, out, batch


def finite(values: dict[str, float]) -> bool:
    return all(math.isfinite(v) for v in values.values())


def _without_colour(grad: torch.Tensor) -> torch.Tensor:
    """The texture's gradient with channels 0-2 (the projected colours) zeroed."""
    grad = grad.clone()
    grad[:3] = 0
    return grad
