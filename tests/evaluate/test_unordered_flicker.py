"""A photo set's views are no sequence: evaluating them reports no flicker."""

import math

import torch

from morf.train.project_run import evaluate_frames


class _Avatar:
    def render(self, uv, uv_mask):
        return uv_mask.expand(-1, 3, -1, -1) * 0.5, uv_mask


class _Batch:
    def __init__(self, i):
        g = torch.Generator().manual_seed(i)
        self.uv_mask = torch.ones(1, 1, 8, 8)
        self.uv = torch.zeros(1, 2, 8, 8)
        self.image = torch.rand(1, 3, 8, 8, generator=g)
        self.mask = torch.ones(1, 1, 8, 8)


class _Frames:
    num_frames = 3

    def batch(self, idx):
        return _Batch(idx[0])


def test_flicker_only_for_frames_in_order():
    ordered = evaluate_frames(_Avatar(), _Frames(), background="black")
    views = evaluate_frames(_Avatar(), _Frames(), background="black", ordered=False)
    assert math.isfinite(ordered.temporal) and ordered.temporal > 0
    assert math.isnan(views.temporal)
    assert views.psnr_person == ordered.psnr_person
