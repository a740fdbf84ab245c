"""Loss terms give known values on known configurations."""

import torch

from morf.fitting.losses import (dice_loss_per_frame, geman_mcclure, keypoint_loss, keypoint_residual_px,
                                 rotation_temporal_loss, temporal_loss, worst_keypoint_residual_px)


def test_dice_identical_and_disjoint():
    a = torch.zeros(1, 8, 8)
    a[0, 2:5, 2:6] = 1
    b = torch.zeros(1, 8, 8)
    b[0, 6:8, 6:8] = 1
    assert dice_loss_per_frame(a, a, eps=0).item() == 0.0
    assert dice_loss_per_frame(a, b, eps=0).item() == 1.0
    half = a.clone()
    half[0, 2:5, 4:6] = 0  # half of a: dice = 2 * 6 / (12 + 6)
    assert abs(dice_loss_per_frame(half, a, eps=0).item() - (1 - 12 / 18)) < 1e-6


def test_geman_mcclure_saturates():
    r2 = torch.tensor([0.0, 1e-4, 1e6])
    v = geman_mcclure(r2, sigma=2.0)
    assert v[0] == 0
    assert abs(v[1].item() - 1e-4) < 1e-6  # quadratic near zero
    assert abs(v[2].item() - 4.0) < 1e-3  # saturates at sigma^2


def test_keypoint_loss_zero_at_ground_truth_and_confidence_weighted():
    proj = torch.rand(3, 23, 2) * 100
    det = torch.cat([proj, torch.ones(3, 23, 1)], -1)
    assert keypoint_loss(proj, det, scale=5.0, sigma=5.0).abs().max().item() == 0.0
    moved = det.clone()
    moved[0, 4, :2] += 10
    loss = keypoint_loss(proj, moved, scale=5.0, sigma=5.0)
    assert loss[0] > 0 and loss[1] == 0
    moved[0, 4, 2] = 0  # no confidence: no loss
    assert keypoint_loss(proj, moved, scale=5.0, sigma=5.0)[0] == 0
    assert keypoint_residual_px(proj, det).abs().max() < 1e-6


def test_worst_residual_sees_one_limb():
    proj = torch.zeros(1, 23, 2)
    det = torch.cat([proj.clone(), torch.ones(1, 23, 1)], -1)
    det[0, [7, 9], 0] = 60.0  # elbow and wrist off by 60 px
    worst = worst_keypoint_residual_px(proj, det, k=3)
    mean = keypoint_residual_px(proj, det)
    assert abs(worst.item() - 40.0) < 1e-4 and mean.item() < 6


def test_temporal_terms():
    x = torch.arange(4.0)[:, None].expand(4, 3)
    assert torch.allclose(temporal_loss(x), torch.full((3,), 3.0))
    R = torch.eye(3).expand(5, 3, 3)
    assert rotation_temporal_loss(R).abs().max() == 0


def test_rotation_acceleration_is_free_for_a_steady_turn():
    import math

    from morf.body.rotations import axis_angle_to_matrix
    from morf.fitting.losses import rotation_acceleration_loss, rotation_temporal_loss

    yaw = torch.arange(10, dtype=torch.float64) * math.radians(7.5)  # a brisk spin, 7.5 degrees a frame
    R = axis_angle_to_matrix(torch.stack([torch.zeros(10), torch.zeros(10), yaw], -1).double())
    steady = rotation_acceleration_loss(R).sum()
    assert rotation_temporal_loss(R).sum() > 30 * steady  # the speed term charges the turn itself
    jerk = yaw.clone()
    jerk[5] += math.radians(3.0)  # one frame's orientation off by 3 degrees
    Rj = axis_angle_to_matrix(torch.stack([torch.zeros(10), torch.zeros(10), jerk], -1).double())
    assert rotation_acceleration_loss(Rj).sum() > 4 * steady
    # pair weights: a triple spanning an unordered pair costs nothing
    w = torch.ones(9, dtype=torch.float64)
    w[4] = 0.0
    assert rotation_acceleration_loss(Rj, w)[3:5].abs().max() == 0.0
    assert rotation_acceleration_loss(R[:2]).numel() == 0
