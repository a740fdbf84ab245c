"""A turn seen in 8 views 45 degrees apart: fitting that knows how far apart the frames are keeps
each body turned with its view; pulling them together as 33 ms neighbours does not."""

import dataclasses
import math

import numpy as np
import torch

from morf.bench.fitting import root_error_deg
from morf.fitting import finalize, fit_sequence, preset

from .synthetic import SHAPE, make_inputs, turning_poses


def test_views_far_apart_are_not_pulled_together(body_model):
    pose = turning_poses(body_model, 8, turn=2 * math.pi * 7 / 8, cycles=0.5)
    inputs, _ = make_inputs(body_model, pose, SHAPE, size=256, sil_res=64, eval_res=64)
    inputs = dataclasses.replace(inputs, frame_times=np.arange(8) * 0.8)  # 0.8 s between the views
    true = pose.rotvecs.numpy()
    cfg = preset("tiny").replace(overlays=False)
    spaced = finalize(body_model, inputs, cfg, fit_sequence(body_model, inputs, cfg, device=torch.device("cpu")))[0]
    assert root_error_deg(spaced.rotvecs, true).max() < 15.0
    assert spaced.twist_deg.max() < 15.0
    # the same fit taking the views for video neighbours lags the turn at both ends of the sequence
    dense = cfg.replace(frame_spacing=False)
    lagged = fit_sequence(body_model, inputs, dense, device=torch.device("cpu"))
    assert root_error_deg(lagged.rotvecs.numpy(), true).max() > 25.0


def test_a_brisk_turn_is_not_held_back_at_its_ends(body_model):
    # 16 video frames 33 ms apart, turning 7.5 degrees a frame (225 degrees a second): the first
    # stage finds the turn, so the temporal terms treat the frames as 3-4 apart
    pose = turning_poses(body_model, 16, turn=math.radians(7.5 * 15), cycles=0.5)
    inputs, _ = make_inputs(body_model, pose, SHAPE, size=256, sil_res=64, eval_res=64)
    inputs = dataclasses.replace(inputs, frame_times=np.arange(16) / 30.0)
    true = pose.rotvecs.numpy()
    cfg = preset("tiny").replace(overlays=False).with_settings(["stages.0.iterations=30", "stages.1.iterations=40"])
    aware = fit_sequence(body_model, inputs, cfg, device=torch.device("cpu"))
    assert aware.spacing.source == "times" and np.median(aware.spacing.gaps) > 3.0
    held = fit_sequence(body_model, inputs, cfg.replace(frame_spacing=False), device=torch.device("cpu"))
    ends = [0, 15]
    err_aware, err_held = root_error_deg(aware.rotvecs.numpy(), true), root_error_deg(held.rotvecs.numpy(), true)
    assert err_aware[ends].max() < 10.0 and np.median(err_aware) < 4.0
    assert err_held[ends].mean() > 2 * err_aware[ends].mean()
