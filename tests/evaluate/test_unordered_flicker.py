"""A photo set's views are no sequence: evaluating them reports no flicker."""

import math

import torch

from morf.train.project_run import evaluate_frames


class _Avatar:
    def render(self, uv, uv_mask):
        return uv_mask.expand(-1, 3, -1, -1) * 0.5, uv_mask


class _Batch:
    def __init__(self, i, side):
        g = torch.Generator().manual_seed(i)
        self.uv_mask = torch.ones(1, 1, side, side)
        self.uv = torch.zeros(1, 2, side, side)
        self.image = torch.rand(1, 3, side, side, generator=g)
        self.mask = torch.ones(1, 1, side, side)


class _Frames:
    num_frames = 3

    def __init__(self, side=8):
        self.side = side

    def batch(self, idx):
        return _Batch(idx[0], self.side)


def test_flicker_only_for_frames_in_order():
    ordered = evaluate_frames(_Avatar(), _Frames(), background="black")
    views = evaluate_frames(_Avatar(), _Frames(), background="black", ordered=False)
    assert math.isfinite(ordered.temporal) and ordered.temporal > 0
    assert math.isnan(views.temporal)
    assert views.psnr_person == ordered.psnr_person
    assert ordered.warp_flicker is None  # under 32 px: no flow


def test_warping_error_for_frames_in_order_reaches_the_eval_scores():
    from morf.evaluate.results import TargetScores

    ordered = evaluate_frames(_Avatar(), _Frames(48), background="black")
    views = evaluate_frames(_Avatar(), _Frames(48), background="black", ordered=False)
    render, real = ordered.warp_flicker
    assert real > 0 and render >= 0 and views.warp_flicker is None  # a flat render against noise frames
    scores = TargetScores.of(ordered, None, 48)
    assert (scores.warp_flicker, scores.warp_flicker_real) == (render, real)
    assert TargetScores.from_dict(scores.to_dict()) == scores
