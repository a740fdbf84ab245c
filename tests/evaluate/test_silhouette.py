"""morf eval's mask IoU: the rendered mask against the real person mask."""

from __future__ import annotations

import math

import numpy as np
import torch

from morf.evaluate.results import TargetScores
from morf.evaluate.silhouette import mask_iou, mask_iou_of
from morf.train.frames import FrameSet


class _CoverageAvatar:
    """Renders a mask that is the mesh coverage, shrunk by ``cut`` rows at the bottom (a cut-away hem)."""

    def __init__(self, cut: int = 0):
        self.cut = cut

    def render(self, uv, uv_mask):
        alpha = uv_mask.float().unsqueeze(1).clone()
        if self.cut:
            rows = alpha[0, 0].any(1).nonzero()[:, 0]
            alpha[:, :, rows.max() - self.cut + 1:] = 0
        return torch.zeros(alpha.shape[0], 3, *alpha.shape[2:]), alpha


def test_mask_iou_of():
    a = np.zeros((4, 4), bool)
    b = a.copy()
    a[:2] = True
    b[1:3] = True
    assert mask_iou_of(a, b) == 4 / 12
    assert math.isnan(mask_iou_of(np.zeros((2, 2), bool), np.zeros((2, 2), bool)))


def test_mask_iou_falls_when_the_render_cuts_the_person_away():
    m = np.zeros((2, 16, 16), bool)
    m[:, 2:14, 4:12] = True  # 12 rows x 8 columns
    fs = FrameSet.from_float(np.zeros((2, 16, 16, 3)), m, np.zeros((2, 16, 16, 2)), m, np.zeros((2, 1, 3)))
    assert mask_iou(_CoverageAvatar(), fs) == 1.0
    assert mask_iou(_CoverageAvatar(cut=3), fs) == round(9 / 12, 5)


def test_mask_iou_is_kept_in_eval_json():
    s = TargetScores(psnr=20.0, ssim=0.9, psnr_person=18.0, ssim_person=0.7, temporal=0.05,
                     background=(0.5, 0.5, 0.5), frames=3, lpips=None, lpips_person=None, resolution=64,
                     mask_iou=0.93)
    d = s.to_dict()
    assert d["mask_iou"] == 0.93 and TargetScores.from_dict(d).metric("mask_iou") == 0.93
    assert "mask_iou" not in TargetScores.from_dict({**d, "mask_iou": None}).to_dict()
