"""How far apart frames are: gaps from times, from the heading change, none between unordered
views; the temporal terms and the heading choice scaled by them."""

import numpy as np
import pytest
import torch

from morf.fitting import frame_spacing
from morf.fitting.global_init import _choose_sequence
from morf.fitting.losses import rotation_temporal_loss, temporal_loss
from morf.fitting.params import yaw_matrix


def _yaw(deg):
    return yaw_matrix(torch.deg2rad(torch.as_tensor(deg, dtype=torch.float64))).numpy()


def test_gaps_from_frame_times():
    s = frame_spacing.from_times(np.array([0.0, 1 / 30, 2 / 30, 0.8, 1.6]))
    assert s.source == "times"
    assert s.gaps == pytest.approx([1, 1, 22, 24], rel=1e-6)
    assert s.temporal_weights() == pytest.approx([1, 1, 1 / 22 ** 2, 1 / 24 ** 2])
    assert s.neighbours().tolist() == [True, True, False, False]
    # a faster camera is not smoothed harder than the 30 fps the weights were tuned at
    assert frame_spacing.from_times(np.arange(5) / 120.0).gaps == pytest.approx([1, 1, 1, 1])


def test_gaps_from_heading_change_between_frames():
    dense = frame_spacing.from_heading(_yaw(np.arange(10) * 2.0))  # a video: 2 degrees a frame
    assert dense.gaps == pytest.approx(np.ones(9))
    sparse = frame_spacing.from_heading(_yaw(np.arange(8) * 45.0))  # photos 45 degrees apart
    assert sparse.source == "heading"
    assert sparse.gaps == pytest.approx(np.full(7, 22.5), rel=1e-4)
    assert not sparse.neighbours().any()


def test_unordered_views_have_no_neighbours():
    s = frame_spacing.unordered(5)
    assert s.unordered and np.isinf(s.gaps).all()
    assert (s.temporal_weights() == 0).all() and (s.switch_weights() == 0).all()
    assert not s.neighbours().any()
    assert "unordered" in s.describe()


def test_temporal_terms_take_pair_weights():
    x = torch.tensor([[0.0], [1.0], [3.0]])
    assert temporal_loss(x).tolist() == [1.0, 4.0]
    assert temporal_loss(x, torch.tensor([1.0, 0.25])).tolist() == [1.0, 1.0]
    R = torch.as_tensor(_yaw([0.0, 10.0, 100.0]))
    full = rotation_temporal_loss(R)
    assert rotation_temporal_loss(R, torch.tensor([1.0, 0.0], dtype=R.dtype)).tolist() == [full[0].item(), 0.0]


def test_heading_choice_turns_freely_between_far_frames():
    """Two headings per frame, 0 and 180 degrees; the data prefers a 180-degree turn at frame 2.
    As video neighbours the turn costs more than the data gains; as views it is free."""
    R = torch.as_tensor(np.stack([_yaw([0.0, 180.0])] * 4))
    loss = torch.tensor([[0.0, 1.0], [0.0, 1.0], [1.0, 0.0], [1.0, 0.0]], dtype=R.dtype)
    video = _choose_sequence(loss, R, torch.full((3,), 0.5, dtype=R.dtype))
    assert video.tolist() == [0, 0, 0, 0]
    views = _choose_sequence(loss, R, torch.as_tensor(0.5 * frame_spacing.unordered(4).switch_weights()))
    assert views.tolist() == [0, 0, 1, 1]


def test_a_brisk_turn_counts_as_frames_further_apart():
    from morf.fitting.frame_spacing import from_times, turn_speed_deg, with_turn_speed

    def yaw(deg):
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        R = np.zeros((len(deg), 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
        return R

    times = np.arange(40) / 30.0
    slow = yaw(np.arange(40) * 2.0)  # the speed the weights were set at
    fast = yaw(np.arange(40) * 8.0)
    assert turn_speed_deg(fast) == pytest.approx(np.full(39, 8.0))
    assert with_turn_speed(from_times(times), slow).gaps == pytest.approx(np.ones(39))
    assert with_turn_speed(from_times(times), fast).gaps == pytest.approx(np.full(39, 4.0))
    # frame-to-frame noise of the first stage without a turn is not taken for one
    rng = np.random.default_rng(0)
    jitter = yaw(rng.normal(0.0, 4.0, 40))
    assert with_turn_speed(from_times(times), jitter).gaps == pytest.approx(np.ones(39))
