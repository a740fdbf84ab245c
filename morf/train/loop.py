"""``train_avatar``: the training stage on a FrameSet, resumable, stoppable, with progress.

Order of work: main optimisation (checkpoint every few minutes, and before honouring a stop) ->
bake the texture (warp at neutral pose + mean latent) -> inpainting fine-tune of unseen texels
(when pseudo views are available) -> ``avatar.pt``. A killed or stopped run resumes from its
last checkpoint; a finished run is not trained again. Opening the run, recovering from a
divergence and finishing the avatar are in ``run_session.py``.
"""

from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from morf.avatar.warp import offsets_to_rgb, warp_texture
from morf.errors import TrainingDiverged
from morf.pipeline.control import Progress, StageControl
from morf.train.config import TrainConfig
from morf.train.frames import FrameSet
from morf.train.health import CollapseMonitor
from morf.train.inpaint_views import InpaintViews
from morf.train.run_session import finish_avatar, handle_divergence, open_run, recovery_policy, save_checkpoint

SNAPSHOT_EVERY = 100  # steps between in-memory snapshots of a healthy state (rollback targets)


@dataclass(frozen=True)
class TrainResult:
    """Outcome of :func:`train_avatar`.

    Fields:
        run_dir: the run folder; step: steps done; losses: last logged losses;
        train_minutes: wall time over all sessions; resumed_from: the step this session started at.
    """

    run_dir: Path
    step: int
    losses: dict[str, float]
    train_minutes: float
    resumed_from: int

    def to_dict(self) -> dict:
        """JSON-ready: ``run_dir`` as a string, ``losses`` copied."""
        return {**asdict(self), "run_dir": str(self.run_dir)}


def _preview(out, batch, texture: torch.Tensor | None = None) -> dict[str, np.ndarray]:
    """Images for the studio: the render, its target, and with warping the frame's offset field
    ("warp") and its effect on the texture ("warp_effect": channels 0-2 before | after warping)."""
    def img(t):
        return (t.detach().clamp(0, 1).permute(1, 2, 0).cpu().numpy() * 255).astype(np.uint8)

    images = {"render": img(out.rgb[0]), "target": img(batch.image[0] * batch.mask[0])}
    if out.offsets is not None:
        images["warp"] = offsets_to_rgb(out.offsets[0]).numpy()
        if texture is not None:
            with torch.no_grad():
                rgb = texture.detach()[:3].float()
                lo = rgb.amin(dim=(1, 2), keepdim=True)
                rgb = (rgb - lo) / (rgb.amax(dim=(1, 2), keepdim=True) - lo).clamp_min(1e-6)
                warped = warp_texture(rgb, out.offsets[:1].detach().float())[0]
            images["warp_effect"] = np.concatenate([img(rgb), img(warped)], axis=1)
    return images


def train_avatar(frames: FrameSet, run_dir: str | Path, cfg: TrainConfig, texture_init: torch.Tensor,
                 control: StageControl | None = None, perceptual=None, inpaint: InpaintViews | None = None,
                 shape: torch.Tensor | None = None, camera=None, notes: list[str] | None = None,
                 zoom_frames: FrameSet | None = None, detail_centres: np.ndarray | None = None) -> TrainResult:
    """Train (or resume) a run in ``run_dir``.

    Args:
        frames: the training frames; texture_init: (C, Ht, Wt) initial neural texture (ignored on resume);
        control: progress + pause/stop; perceptual: a PerceptualLoss or None (then the discriminator's
        feature matching is used when the config has adversarial terms, else the SSIM term alone;
        the log says which); inpaint: pseudo views for the fine-tune or None;
        shape, camera: stored with the avatar for export; notes: extra lines for the log;
        zoom_frames: the same frames at ``cfg.zoom_resolution`` (every other step), or None;
        detail_centres: (N, 3, 2) pixel centres of the head and hands in ``zoom_frames``
        (:mod:`morf.train.detail`), needed with ``cfg.detail_every``.
    Raises:
        TrainingDiverged: NaN/inf or a collapsed mask (``health.py``) that rolling back with halved
            learning rates (``cfg.max_recoveries`` times; to the last snapshot or checkpoint, or to
            the initial state before the first snapshot: ``recovery.py``) did not cure, or a mask that
            did not form even after a restart with the adversarial terms held; the last good
            checkpoint is kept.
        StopRequested: the user stopped; a checkpoint of the current step was written first.
    """
    control = control or StageControl()
    run, trainer = open_run(frames, run_dir, cfg, texture_init, perceptual, notes, zoom_frames,
                           detail_centres)
    resumed_from = trainer.step
    if run.is_done and trainer.step >= cfg.steps:
        return TrainResult(run.root, trainer.step, {}, trainer.elapsed_s / 60, resumed_from)
    t_session = time.monotonic()
    last_ckpt = time.monotonic()
    losses: dict[str, float] = {}
    monitor = CollapseMonitor()
    policy = recovery_policy(run, trainer, SNAPSHOT_EVERY)
    while trainer.step < cfg.steps:
        if control.stop_requested:
            t_session = save_checkpoint(run, trainer, t_session)
            policy.checkpoint_saved(trainer.step)
            run.log(f"stopped at step {trainer.step}")
        control.check()
        try:
            losses, out, batch = trainer.train_step()
            collapse = monitor.update(losses)
            if collapse:
                raise TrainingDiverged(f"training diverged at step {trainer.step}: {collapse}")
        except TrainingDiverged as e:
            monitor, t_session = handle_divergence(str(e), run, trainer, policy, monitor, t_session)
            continue
        s = trainer.step
        if trainer.hold_adversarial and monitor.formed:
            trainer.hold_adversarial = False
            run.log(f"the mask formed at step {s}: adversarial terms on")
        if s % cfg.log_every == 0 or s == cfg.steps:
            run.append_metrics({"step": s, "time_s": trainer.elapsed_s + time.monotonic() - t_session, **losses})
        if s % cfg.report_every == 0 or s == cfg.steps:
            control.report(Progress("train", s, cfg.steps, f"training {cfg.method}", losses,
                                    _preview(out, batch, trainer.model.texture.texture)))
        if policy.wants_snapshot(s, monitor.healthy):
            policy.keep_snapshot(s, copy.deepcopy(trainer.state_dict()))
        if time.monotonic() - last_ckpt > cfg.checkpoint_minutes * 60 and monitor.healthy:
            t_session = last_ckpt = save_checkpoint(run, trainer, t_session)
            policy.checkpoint_saved(trainer.step)
    save_checkpoint(run, trainer, t_session)
    run.log(f"main stage done at step {trainer.step}: " + ", ".join(f"{k} {v:.4f}" for k, v in losses.items()))
    finish_avatar(run, trainer, frames, losses, control, inpaint, shape, camera)
    return TrainResult(run.root, trainer.step, losses, trainer.elapsed_s / 60, resumed_from)
