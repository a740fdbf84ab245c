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
