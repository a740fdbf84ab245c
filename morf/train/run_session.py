"""The parts of one ``train_avatar`` session around its step loop: opening (or resuming) the run,
checkpointing and restoring with the wall time kept, carrying out a recovery after a divergence,
and finishing the avatar once the main stage is done.

``t_session`` below is the monotonic time the session's current stretch of wall time started:
``trainer.elapsed_s`` plus the time since then is the run's training time.
"""

from __future__ import annotations

import copy
import json
import time
from pathlib import Path

import torch

from morf.errors import InputError, TrainingDiverged
from morf.io import atomic_write_text
from morf.pipeline.control import Progress, StageControl
from morf.train.config import TrainConfig
from morf.train.frames import FrameSet
from morf.train.health import CollapseMonitor
from morf.train.inpaint_views import InpaintViews
from morf.train.recovery import RecoveryPolicy
from morf.train.run_dir import RunDir
from morf.train.run_files import last_step
from morf.train.start_log import log_start
from morf.train.trained_avatar import save_trained_avatar
from morf.train.trainer import Trainer


def open_run(frames: FrameSet, run_dir: str | Path, cfg: TrainConfig, texture_init: torch.Tensor, perceptual,
             notes: list[str] | None, zoom_frames: FrameSet | None,
             detail_centres=None) -> tuple[RunDir, Trainer]:
    """The run folder (its config written, or checked against ``cfg``) and a trainer, resumed from
    the checkpoint when there is one (else the start is logged). Raises InputError as ``train_avatar``."""
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
    if cfg.detail_every and detail_centres is None:
        raise InputError("the config asks for crops around the head and hands; no detail centres were given")
    trainer = Trainer(cfg, frames, texture_init, perceptual=perceptual, zoom_frames=zoom_frames,
                      detail_centres=detail_centres)
    if run.has_checkpoint:
        trainer.load_state_dict(run.load_checkpoint(map_location=trainer.device))
        dropped = drop_metrics_after(run, trainer.step)
        run.log(f"resumed at step {trainer.step}" + (f" ({dropped} metrics lines of later steps, from the "
                                                      "session that stopped, dropped)" if dropped else ""))
    else:
        drop_metrics_after(run, 0)  # a session killed before its first checkpoint starts over
        log_start(run, cfg, frames, trainer.device, trainer.bf16, perceptual is not None, notes, trainer.bf16_note)
    return run, trainer


def drop_metrics_after(run: RunDir, step: int) -> int:
    """Remove the metrics.jsonl lines of steps after ``step`` (those a killed session logged past
    its last checkpoint: the resumed session logs them again) and a line cut by the kill; returns
    how many went. The file is rewritten atomically, and only when something goes."""
    if not run.metrics_path.is_file():
        return 0
    lines = run.metrics_path.read_text().splitlines()
    keep = []
    for line in lines:
        try:
            row_step = last_step([json.loads(line)])
        except (json.JSONDecodeError, AttributeError):
            continue
        if row_step <= step:
            keep.append(line)
    if len(keep) < len(lines):
        atomic_write_text(run.metrics_path, "".join(line + "\n" for line in keep))
    return len(lines) - len(keep)


def recovery_policy(run: RunDir, trainer: Trainer, snapshot_every: int) -> RecoveryPolicy:
    """The session's rollback policy, knowing the checkpoint on disk and, for a run at step 0, its initial state."""
    # A run that starts at step 0 keeps its initial state: a mask that never formed restarts from it
    # (no earlier state has a mask), and so does a collapse before the first snapshot or checkpoint.
    initial = copy.deepcopy(trainer.state_dict()) if trainer.step == 0 and not trainer.hold_adversarial else None
    return RecoveryPolicy(trainer.cfg.max_recoveries, snapshot_every, trainer.step if run.has_checkpoint else None,
                          run.checkpoint_path, initial)


def save_checkpoint(run: RunDir, trainer: Trainer, t_session: float) -> float:
    """Add the wall time since ``t_session`` to the trainer and write a checkpoint; returns the new session start."""
    trainer.elapsed_s += time.monotonic() - t_session
    run.save_checkpoint(trainer.state_dict())
    return time.monotonic()


def restore_state(trainer: Trainer, state: dict, t_session: float) -> float:
    """Load an earlier state, keeping the wall time spent (the lost steps took time too);
    returns the new session start."""
    spent = trainer.elapsed_s + time.monotonic() - t_session
    trainer.load_state_dict(state)
    trainer.elapsed_s = spent
    return time.monotonic()


def handle_divergence(reason: str, run: RunDir, trainer: Trainer, policy: RecoveryPolicy, monitor: CollapseMonitor,
                      t_session: float) -> tuple[CollapseMonitor, float]:
    """Carry out the policy's answer to a divergence (``reason``: its message): restart or roll
    back, logging both. Returns the health monitor to go on with and the new session start.
    Raises TrainingDiverged when the policy gives up."""
    run.log(f"diverged: {reason}")
    recovery = policy.decide(reason, monitor.kind)
    if recovery.action == "give_up":
        raise TrainingDiverged(recovery.note) from None
    state = recovery.state if recovery.state is not None else run.load_checkpoint(map_location=trainer.device)
    t_session = restore_state(trainer, state, t_session)
    if recovery.action == "restart":
        trainer.hold_adversarial, monitor = True, CollapseMonitor()
        # the step-0 restart replaces any checkpoint of the failed attempt
        t_session = save_checkpoint(run, trainer, t_session)
        policy.checkpoint_saved(trainer.step)
    else:
        trainer.scale_learning_rates(recovery.lr_factor)
        monitor.reset()
    run.log(recovery.note)
    return monitor, t_session


def finish_avatar(run: RunDir, trainer: Trainer, frames: FrameSet, losses: dict[str, float], control: StageControl,
                  inpaint: InpaintViews | None, shape: torch.Tensor | None, camera) -> None:
    """Make and write ``avatar.pt`` from the trained state: the averaged weights when kept, the
    texture as trained (warp faded out) or baked, the trained colours when frozen, the inpainting
    fine-tune when pseudo views are given; then report the stage done."""
    cfg = trainer.cfg
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
