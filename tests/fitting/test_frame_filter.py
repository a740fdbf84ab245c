"""The automatic frame filter flags injected bad frames and leaves good ones alone."""

import numpy as np

from morf.fitting.config import FilterConfig
from morf.fitting.frame_filter import filter_frames, pose_change_deg


def _sequence(n=30, seed=0):
    rng = np.random.default_rng(seed)
    residual = 3 + rng.random(n)
    iou = 0.93 + 0.02 * rng.random(n)
    t = np.linspace(0, np.pi, n)
    root = np.stack([np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]) for a in t])
    body = 0.02 * rng.standard_normal((n, 19, 3)).cumsum(0) * 0.1
    return residual, iou, root, body


def _run(residual, iou, root, body, detected=None, confident=None):
    n = len(residual)
    return filter_frames(residual_px=residual, confident=np.full(n, 23) if confident is None else confident,
                         detected=np.ones(n, bool) if detected is None else detected, iou=iou,
                         change_deg=pose_change_deg(root, body), image_height=512, cfg=FilterConfig())


def test_clean_sequence_keeps_every_frame():
    assert _run(*_sequence()) == {}


def test_flags_each_kind_of_bad_frame_with_a_reason():
    residual, iou, root, body = _sequence()
    residual[5] = 60.0
    iou[12] = 0.6
    body[20, 3] += 1.2  # a one-frame glitch of one bone (about 69 degrees)
    detected = np.ones(len(residual), bool)
    detected[25] = False
    rejected = _run(residual, iou, root, body, detected=detected)
    assert set(rejected) == {5, 12, 20, 25}
    assert rejected[5].startswith("keypoint residual 60 px")
    assert rejected[12].startswith("silhouette IoU 0.60")
    assert rejected[20].startswith("pose jump")
    assert rejected[25] == "no person detected"


def test_a_real_motion_step_is_not_a_jump():
    residual, iou, root, body = _sequence()
    body[15:, 3] += 1.0  # the pose changes once and stays: only one neighbour differs
    assert _run(residual, iou, root, body) == {}
