"""The header a new training run writes to its ``train.log``: what runs on what (method, preset,
frames, device), which perceptual loss and whether bfloat16 autocast is on, then the caller's notes
(the fits and frames cache, crops, hold-out ... from :mod:`morf.train.project_run`)."""

from __future__ import annotations

from morf.train.bf16_check import OFF_NOT_NATIVE
from morf.train.config import TrainConfig
from morf.train.frames import FrameSet
from morf.train.run_files import RunFiles


def log_start(run: RunFiles, cfg: TrainConfig, frames: FrameSet, device, bf16: bool, vgg: bool,
              notes: list[str] | None = None, bf16_note: str | None = None) -> None:
    """Write the header of a run that starts at step 0.

    Args:
        device: the trainer's device; bf16: whether the trainer's autocast is on (only logged when
        the config asks for it); vgg: whether a VGG-16 perceptual loss was given; notes: extra lines;
        bf16_note: the trainer's own words for its choice (``Trainer.bf16_note``), logged instead.
    """
    run.log(f"start: method {cfg.method}, preset {cfg.preset}, {frames.num_frames} frames at "
            f"{frames.resolution} px, device {device}")
    if vgg:
        run.log("perceptual loss: VGG-16")
    elif cfg.w_gan > 0 and cfg.w_feature_matching > 0:
        run.log("perceptual loss: no VGG-16 weights (--vgg / MORF_VGG16_WEIGHTS); using discriminator "
                "feature matching instead")
    else:
        run.log("perceptual loss: none (no VGG-16 weights given with --vgg / MORF_VGG16_WEIGHTS); "
                f"structure from the SSIM term (weight {cfg.w_ssim})")
    if cfg.bf16:
        run.log("bfloat16 autocast: " + (bf16_note or ("on" if bf16 else OFF_NOT_NATIVE)))
    for line in notes or []:
        run.log(line)
