"""Pareto-front computation on known point sets."""

import numpy as np
import pytest

from morf.bench.front import near_front, pareto_front


def test_front_of_known_points():
    # (quality up, fps up)
    pts = [[30, 10], [28, 20], [25, 40], [27, 15], [24, 35], [30, 5]]
    assert pareto_front(pts).tolist() == [True, True, True, False, False, False]


def test_front_minimise_second_objective_and_missing_values():
    # (quality up, minutes down); a NaN point is never on the front
    pts = [[30, 10], [28, 5], [29, 20], [np.nan, 1], [31, 30]]
    assert pareto_front(pts, (True, False)).tolist() == [True, True, False, False, True]


def test_ties_stay_on_the_front():
    assert pareto_front([[1, 1], [1, 1], [0, 0]]).tolist() == [True, True, False]


def test_near_front_margin():
    pts = [[30.0, 20.0], [29.8, 20.0], [28.0, 20.0], [35.0, 5.0]]
    assert near_front(pts, 1, (0.5, 0.0))  # 0.2 dB below an equally fast point: near
    assert not near_front(pts, 2, (0.5, 0.0))  # 2 dB below an equally fast point: not near
    assert near_front(pts, 3, (0.5, 0.0))  # best quality, slowest: on the front


def test_near_front_counts_differences_inside_the_margin_as_equal():
    pts = [[26.6, 23.9], [23.8, 24.7], [23.5, 40.0], [26.0, 30.0]]
    # 2.8 dB under a point 3 % slower: near only when fps must match exactly
    assert near_front(pts[:2], 1, (0.5, 0.0))
    assert not near_front(pts[:2], 1, (0.5, 0.2 * 24.7))
    # 0.3 dB under a point 62 % faster: beaten once 0.3 dB counts as equal quality
    assert not near_front([[23.8, 24.7], [23.5, 40.0]], 0, (0.5, 0.2 * 24.7))
    assert near_front([[23.8, 24.7], [23.5, 40.0]], 0, (0.0, 0.2 * 24.7))
    assert near_front(pts, 3, (0.5, 0.2 * 30.0))  # 0.6 dB under the best, which is 20 % slower: near


def test_quality_gap_and_its_standard_error():
    from morf.bench.front import quality_gap

    runs = {"base": [21.0, 22.0, 23.0], "small": [20.0, 21.0, 22.0], "fast": [30.0, None], "auto": [20.5, 21.5]}
    fps = {"base": 25.0, "small": 26.0, "fast": 10.0, "auto": 24.0}
    gap, se, other = quality_gap(runs, fps, "auto", fps_margin=4.8)  # "fast" is too slow to compete
    assert other == "base" and gap == pytest.approx(1.0)
    assert se == pytest.approx((1.0 / 3 + 0.5 / 2) ** 0.5)
    gap, se, other = quality_gap(runs, fps, "auto", fps_margin=20.0)  # now it competes, with one training
    assert (other, gap, se) == ("fast", pytest.approx(9.0), None)
    assert quality_gap({"auto": [20.0]}, {"auto": 24.0}, "auto", 5.0) == (None, None, None)
