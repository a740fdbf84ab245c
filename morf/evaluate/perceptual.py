"""LPIPS of a trained avatar's renders against the real frames (:mod:`morf.avatar.lpips`), on the
images the other scores compare: render and frame both composited over the capture's backdrop
colour (:func:`morf.avatar.metrics.composite_over`), as
:func:`morf.train.project_run.evaluate_frames` composites them."""

from __future__ import annotations

import torch

from morf.avatar.metrics import composite_over, summarize
from morf.train.frames import FrameSet
from morf.train.trained_avatar import render_batch


@torch.no_grad()
def lpips_scores(metric, avatar, frames: FrameSet, colour: torch.Tensor, batch: int = 2) -> dict:
    """``{"lpips", "lpips_person"}``: the means over the frames of LPIPS over the whole image and
    over the ground-truth person mask (the mask-weighted average, :class:`morf.avatar.lpips.LPIPS`);
    frames without a person are left out of the person mean."""
    whole, person = [], []
    for s in range(0, frames.num_frames, batch):
        b = frames.batch(list(range(s, min(s + batch, frames.num_frames))))
        rgb, alpha = render_batch(avatar, b)
        maps = metric.maps(composite_over(rgb, alpha, colour), composite_over(b.image * b.mask, b.mask, colour))
        whole += metric.reduce(maps).tolist()
        person += metric.reduce(maps, b.mask).tolist()
    return {"lpips": summarize(whole), "lpips_person": summarize(person)}
