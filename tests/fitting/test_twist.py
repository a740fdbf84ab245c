"""The pelvis-shoulder twist: measured on 3D keypoints, penalised past its limit, flagged by the filter."""

import math

import numpy as np
import pytest
import torch

from morf.body.model import BodyPose
from morf.fitting.config import FilterConfig
from morf.fitting.frame_filter import filter_frames, limit_excess
from morf.fitting.pose_prior import JointLimitPrior
from morf.fitting.params import FIT_BONES
from morf.fitting.twist import twist_angle, twist_deg, twist_penalty


def _twisted(model, degrees):
    """Keypoints of the body with its three spine bones turned by ``degrees`` in all about the up axis."""
    n = len(degrees)
    rot = torch.zeros(n, len(model.bone_names), 3)
    for b in ("spine01", "spine02", "spine03"):
        rot[:, model.bone_index(b), 2] = torch.deg2rad(torch.as_tensor(degrees, dtype=torch.float32)) / 3
    rot[:, 0, 2] = 0.7  # the whole body turned: the twist is relative, not a heading
    with torch.no_grad():
        return model(BodyPose(rot, torch.zeros(n, 3)), model.default_shape()).keypoints3d


def test_twist_of_a_body_is_its_spine_turn(body_model):
    kp = _twisted(body_model, [0.0, 20.0, -45.0, 90.0])
    measured = np.degrees(twist_angle(kp.double()).numpy())
    assert measured[0] == pytest.approx(0.0, abs=1.0)
    assert np.abs(measured[1:]) == pytest.approx([20.0, 45.0, 90.0], abs=4.0)
    assert np.sign(measured[1]) == -np.sign(measured[2])


def test_penalty_is_zero_within_the_limit_and_pushes_back_even_at_half_a_turn():
    def kp_with(deg):
        kp = torch.zeros(1, 23, 3, dtype=torch.float64)
        kp[0, 11], kp[0, 12] = torch.tensor([0.1, 0, 0]), torch.tensor([-0.1, 0, 0])
        a = math.radians(deg)
        kp[0, 5] = torch.tensor([0.2 * math.cos(a), 0.2 * math.sin(a), 0.5])
        kp[0, 6] = -kp[0, 5] + torch.tensor([0, 0, 1.0])
        return kp.requires_grad_(True)

    assert twist_deg(kp_with(10).detach().numpy()) == pytest.approx([10.0], abs=1e-6)
    assert twist_penalty(kp_with(20), 25.0).item() == 0.0
    values = [twist_penalty(kp_with(d), 25.0).item() for d in (40, 90, 150, 179)]
    assert values == sorted(values) and values[0] > 0
    kp = kp_with(179)
    twist_penalty(kp, 25.0).sum().backward()
    # moving the left shoulder along the turn's direction would twist further: the gradient resists it
    along = torch.tensor([-math.sin(math.radians(179)), math.cos(math.radians(179)), 0.0], dtype=torch.float64)
    assert (kp.grad[0, 5] * along).sum() > 0


def test_filter_flags_twisted_and_out_of_limit_bodies_with_the_reason(body_model):
    n = 6
    twist = np.full(n, 5.0)
    twist[2] = 150.0
    body = torch.zeros(n, len(FIT_BONES), 3)
    body[4, FIT_BONES.index("upperleg01.L"), 2] = math.radians(170)  # the thigh turned backwards
    excess = JointLimitPrior(body_model).excess_deg(body).numpy()
    assert excess[0].max() == 0.0 and excess[4].max() > 100
    rejected = filter_frames(residual_px=np.full(n, 3.0), confident=np.full(n, 23), detected=np.ones(n, bool),
                             iou=None, change_deg=np.zeros(n - 1), image_height=512, cfg=FilterConfig(),
                             twist_deg=twist, limits=limit_excess(excess, FIT_BONES))
    assert set(rejected) == {2, 4}
    assert rejected[2].startswith("body twisted 150 deg between pelvis and shoulders")
    assert rejected[4].startswith("upperleg01.L") and "beyond its joint limits" in rejected[4]


def test_pose_jumps_are_judged_only_between_neighbours():
    n = 9
    change = np.ones(n - 1)
    change[[3, 4]] = 60.0  # frame 4 differs from both sides
    kw = dict(residual_px=np.full(n, 3.0), confident=np.full(n, 23), detected=np.ones(n, bool), iou=None,
              change_deg=change, image_height=512, cfg=FilterConfig())
    assert set(filter_frames(**kw)) == {4}
    far = np.ones(n - 1, bool)
    far[[3, 4]] = False  # frame 4 is a view seconds away from both
    assert filter_frames(**kw, neighbours=far) == {}
