"""The nearest seen frame as a reference for a hold-out's detail scores.

Each held-out frame is scored against a copy of the nearest frame the runs trained on
(:func:`morf.evaluate.targets.nearest_seen`), its real pixels and mask put where a render would go,
each region moved so that the copy's fitted region sits on the held-out frame's (where the person
stood is the fit's business; how the region looks is the avatar's), then scored in the held-out
frame's regions with the same shift tolerance (:func:`morf.evaluate.detail_eval.copy_scores`).
It measures what the capture itself changes between neighbouring frames (the head turning on,
the gaze, a fold, motion blur): an avatar that gave back the nearest frame it saw, without an
error, would score about this. It is not a bound (an avatar may place its detail better than a
neighbour frame does), but a head score far below it says the avatar loses detail the capture
has, and one near it that the capture allows little more. Ordered captures only: a photo set's
neighbours by number are unrelated views.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from morf.evaluate.detail_eval import DetailResult

REFERENCE_NAME = "nearest seen frame"


@dataclass(frozen=True)
class Reference:
    """Fields: frames: per held-out frame, the seen frame copied; detail: its scores."""

    frames: tuple[int, ...]
    detail: DetailResult

    def to_dict(self) -> dict:
        return {"name": REFERENCE_NAME, "frames": list(self.frames), "detail": self.detail.to_dict()}


def applies(project, target) -> bool:
    """Whether ``target`` gets the reference: a capture hold-out of an ordered capture."""
    return target.kind == "capture" and target.key.startswith("holdout") and not project.unordered_views


@torch.no_grad()
def nearest_frame_reference(project, model, fits, target, frames, camera, colour: torch.Tensor, atlas,
                            max_shift: int, rows=(), offsets=None) -> Reference | None:
    """The reference of hold-out ``target`` whose frames, rasterized through ``camera`` (the body
    dressed by ``offsets``), are ``frames`` (the native-size FrameSet the runs' detail was scored
    on); None without seen frames."""
    from morf.evaluate.detail_eval import copy_scores
    from morf.evaluate.frames import capture_frames
    from morf.evaluate.targets import nearest_seen

    seen = nearest_seen(project, fits, target.holdout, target.frame_ids, target.holdout_by)
    if not seen:
        return None
    copies = capture_frames(project, model, fits, seen, camera, offsets)
    return Reference(seen, copy_scores(frames, copies, colour, atlas, max_shift, rows, target.frame_ids))
