"""``train_avatar``: the training stage on a FrameSet, resumable, stoppable, with progress.

Order of work: main optimisation (checkpoint every few minutes, and before honouring a stop) ->
bake the texture (warp at neutral pose + mean latent) -> inpainting fine-tune of unseen texels
(when pseudo views are available) -> ``avatar.pt``. A killed or stopped run resumes from its
last checkpoint; a finished run is not trained again.
"""

from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from morf.avatar.warp import offsets_to_rgb, warp_texture
from morf.errors import InputError, TrainingDiverged
from morf.pipeline.control import Progress, StageControl
from morf.train.config import TrainConfig
from morf.train.frames import FrameSet
from morf.train.health import CollapseMonitor
from morf.train.recovery import RecoveryPolicy
from morf.train.run_dir import RunDir
from morf.train.start_log import log_start
from morf.train.trained_avatar import save_trained_avatar
from morf.train.trainer import Trainer

SNAPSHOT_EVERY = 100  # steps between in-memory snapshots of a healthy state (rollback targets)


@dataclass(frozen=True)
class InpaintViews:
    """What the inpainting fine-tune needs besides the frames.

    Fields:
        covered: (Ht, Wt) bool texels inside the UV islands.
        make_views: callable () -> (uv (V, H, W, 2) float tensor, uv_mask (V, H, W) bool tensor),
            rasterizations in extreme poses / views (called once, after the main stage).
    """

    covered: np.ndarray
    make_views: Callable[[], tuple[torch.Tensor, torch.Tensor]]


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
                 zoom_frames: FrameSet | None = None) -> TrainResult:
    """Train (or resume) a run in ``run_dir``.

    Args:
        frames: the training frames; texture_init: (C, Ht, Wt) initial neural texture (ignored on resume);
        control: progress + pause/stop; perceptual: a PerceptualLoss or None (then the discriminator's
        feature matching is used when the config has adversarial terms, else the SSIM term alone;
        the log says which); inpaint: pseudo views for the fine-tune or None;
        shape, camera: stored with the avatar for export; notes: extra lines for the log;
        zoom_frames: the same frames at ``cfg.zoom_resolution`` (every other step), or None.
    Raises:
        TrainingDiverged: NaN/inf or a collapsed mask (``health.py``) that rolling back with halved
            learning rates (``cfg.max_recoveries`` times; to the last snapshot or checkpoint, or to
            the initial state before the first snapshot: ``recovery.py``) did not cure, or a mask that
            did not form even after a restart with the adversarial terms held; the last good
            checkpoint is kept.
        StopRequested: the user stopped; a checkpoint of the current step was written first.
    """
    control = control or StageControl()
    run = RunDir(run_dir)
    run.root.mkdir(parents=True, exist_ok=True)
    if run.config_path.is_file():
        saved = run.load_config()
        if saved != cfg:
            raise InputError(f"run {run.root} was started with a different configuration; "
                             "resume it with the same options, or use --restart or another --name")
    else:
        run.save_config(cfg)
    if cfg.zoom_resolution and zoom_frames is None:
        raise InputError(f"the config asks for frames at {cfg.zoom_resolution} px as well; none were given")
    trainer = Trainer(cfg, frames, texture_init, perceptual=perceptual, zoom_frames=zoom_frames)
    if run.has_checkpoint:
        trainer.load_state_dict(run.load_checkpoint(map_location=trainer.device))
        run.log(f"resumed at step {trainer.step}")
    else:
        log_start(run, cfg, frames, trainer.device, trainer.bf16, perceptual is not None, notes)
    resumed_from = trainer.step
    if run.is_done and trainer.step >= cfg.steps:
        return TrainResult(run.root, trainer.step, {}, trainer.elapsed_s / 60, resumed_from)

    def save():
        trainer.elapsed_s += time.monotonic() - t_session
        run.save_checkpoint(trainer.state_dict())
        return time.monotonic()

    t_session = time.monotonic()
    last_ckpt = time.monotonic()
    losses: dict[str, float] = {}
    monitor = CollapseMonitor()
    # A run that starts at step 0 keeps its initial state: a mask that never formed restarts from it
    # (no earlier state has a mask), and so does a collapse before the first snapshot or checkpoint.
    initial = copy.deepcopy(trainer.state_dict()) if trainer.step == 0 and not trainer.hold_adversarial else None
    policy = RecoveryPolicy(cfg.max_recoveries, SNAPSHOT_EVERY, trainer.step if run.has_checkpoint else None,
                            run.checkpoint_path, initial)

    def restore(state: dict, t_session: float) -> float:
        """Load an earlier state, keeping the wall time spent (the lost steps took time too);
        returns the new session start."""
        spent = trainer.elapsed_s + time.monotonic() - t_session
        trainer.load_state_dict(state)
        trainer.elapsed_s = spent
        return time.monotonic()

    while trainer.step < cfg.steps:
        if control.stop_requested:
            t_session = save()
            policy.checkpoint_saved(trainer.step)
            run.log(f"stopped at step {trainer.step}")
        control.check()
        try:
            losses, out, batch = trainer.train_step()
            collapse = monitor.update(losses)
            if collapse:
                raise TrainingDiverged(f"training diverged at step {trainer.step}: {collapse}")
        except TrainingDiverged as e:
            run.log(f"diverged: {e}")
            recovery = policy.decide(str(e), monitor.kind)
            if recovery.action == "give_up":
                raise TrainingDiverged(recovery.note) from None
            state = recovery.state if recovery.state is not None else run.load_checkpoint(map_location=trainer.device)
            t_session = restore(state, t_session)
            if recovery.action == "restart":
                trainer.hold_adversarial, monitor = True, CollapseMonitor()
                t_session = save()  # the step-0 restart replaces any checkpoint of the failed attempt
                policy.checkpoint_saved(trainer.step)
            else:
                trainer.scale_learning_rates(recovery.lr_factor)
                monitor.reset()
            run.log(recovery.note)
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
            t_session = save()
            last_ckpt = t_session
            policy.checkpoint_saved(trainer.step)
    t_session = save()
    run.log(f"main stage done at step {trainer.step}: " + ", ".join(f"{k} {v:.4f}" for k, v in losses.items()))

    if trainer.use_averaged_weights():
        run.log(f"avatar made from the moving average of the weights (decay {cfg.ema_decay})")
    if cfg.warp_faded:  # the last steps trained the unwarped lookups the player makes: nothing to bake
        run.log(f"warp faded out from {cfg.warp_fade_start:g} to {cfg.warp_fade_end:g} of the steps: texture not baked")
        texture = trainer.model.texture.texture.detach().clone()
    else:
        texture = trainer.model.bake()
    if cfg.colour_frozen:  # the projected colours as they were trained: unwarped (the bake's resampling blurred them)
        texture[:3] = trainer.model.texture.texture.detach()[:3]
    renderer = trainer.model.renderer
    extra = {"steps": trainer.step}
    if inpaint is not None and cfg.inpaint_steps > 0:
        texture, extra["inpaint"] = _inpaint(trainer, frames, texture, inpaint, run, control)
    save_trained_avatar(run.avatar_path, texture, renderer, cfg.to_dict(), shape, camera, extra)
    run.log(f"avatar written: {run.avatar_path}")
    control.report(Progress("train", trainer.step, cfg.steps, "done", losses))
    return TrainResult(run.root, trainer.step, losses, trainer.elapsed_s / 60, resumed_from)


def _inpaint(trainer: Trainer, frames: FrameSet, texture: torch.Tensor, inpaint: InpaintViews, run: RunDir,
             control: StageControl):
    from morf.train.inpaint import close_seen, fill_unseen, finetune_unseen, project_rgb_texture

    cfg = trainer.cfg
    size = texture.shape[-1]
    control.report(Progress("train", trainer.step, cfg.steps, "inpainting unseen body parts"))
    rgb, hit = project_rgb_texture(frames, size)
    seen = close_seen(hit)  # pinholes between hit texels count as seen (kept as trained) ...
    covered = inpaint.covered
    rgb = fill_unseen(rgb, hit, covered)  # ... but get a filled colour, not black
    uv, uv_mask = inpaint.make_views()
    dev = trainer.device
    new_tex, hist = finetune_unseen(texture.to(dev), trainer.model.renderer, uv.to(dev), uv_mask.to(dev),
                                    torch.from_numpy(rgb).permute(2, 0, 1).to(dev),
                                    torch.from_numpy(seen | ~covered).to(dev), cfg.inpaint_steps, cfg.inpaint_lr,
                                    seed=cfg.seed)
    info = {"seen_fraction": float((seen & covered).sum() / max(covered.sum(), 1)), "views": int(uv.shape[0]),
            "loss_first": hist[0] if hist else None, "loss_last": hist[-1] if hist else None}
    run.log(f"inpainting: {info}")
    return new_tex, info
