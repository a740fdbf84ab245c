"""Which frames ``morf eval`` scores on a project: hold-out, dataset test labels (no rendering here)."""

from types import SimpleNamespace

import numpy as np

from morf.evaluate.targets import (dataset_test_target, holdout_target, nearest_seen, ordinal, seen_target,
                                   trained_on)
from morf.train.data import BodyFitArrays


def _project(labels, dropped=()):
    n = len(labels)
    return SimpleNamespace(manifest={"dataset": {"splits": labels}}, num_frames=n,
                           training_frames=lambda: [i for i in range(n) if i not in dropped])


def _fits(n):
    return BodyFitArrays(np.zeros((n, 2, 3), np.float32), np.zeros((n, 3), np.float32), np.zeros((1, 6), np.float32),
                         np.ones(n, bool), "fits")


def test_test_labels_become_a_target_and_say_what_was_trained_on():
    p = _project(["train", "test", "train", "test", "", "test"], dropped=(5,))
    fits = _fits(6)
    t = dataset_test_target(p, fits)
    assert t.key == "test-split" and t.frame_ids == (1, 3) and t.applies_to(0) and t.applies_to(4)
    assert trained_on(p, fits, 0, t.frame_ids) == 0  # training leaves the published test frames out
    assert trained_on(p, fits, 3, t.frame_ids) == 0
    assert dataset_test_target(_project(["test"] * 4), _fits(4)) is None  # a test-only import: nothing to compare
    assert dataset_test_target(SimpleNamespace(manifest={}, num_frames=2), _fits(2)) is None


def test_holdout_target_is_the_usable_frames_numbered_0_k_2k():
    p = _project(["train"] * 7, dropped=(2,))
    t = holdout_target(p, _fits(7), 2)
    assert t.frame_ids == (0, 4, 6) and t.holdout == 2 and t.applies_to(2) and not t.applies_to(3)
    assert t.key == "holdout-k2" and not t.applies_to(2, "position")
    assert holdout_target(p, _fits(7), 0) is None
    assert [ordinal(k) for k in (2, 3, 4, 11, 21, 22)] == ["2nd", "3rd", "4th", "11th", "21st", "22nd"]


def test_the_frame_rule_does_not_move_when_other_frames_are_dropped():
    fits = _fits(12)
    before = holdout_target(_project(["train"] * 12), fits, 3)
    after = holdout_target(_project(["train"] * 12, dropped=(1, 4, 5)), fits, 3)
    assert before.frame_ids == (0, 3, 6, 9) and after.frame_ids == (0, 3, 6, 9)
    assert trained_on(_project(["train"] * 12, dropped=(1, 4, 5)), fits, 3, before.frame_ids) == 0
    # the older rule held out every 3rd usable frame: a dropped frame moved every later one
    old = holdout_target(_project(["train"] * 12, dropped=(1,)), fits, 3, "position")
    assert old.key == "holdout-k3-positions" and old.frame_ids == (0, 4, 7, 10)
    assert old.applies_to(3, "position") and not old.applies_to(3)
    assert trained_on(_project(["train"] * 12), fits, 3, old.frame_ids, "position") == 3


def test_nearest_seen_frames_are_training_frames_next_to_the_held_out_ones():
    p = _project(["train"] * 10, dropped=(1,))  # usable 0 2 3 4 5 6 7 8 9; hold-out 3 keeps 0 3 6 9 out
    fits = _fits(10)
    assert holdout_target(p, fits, 3).frame_ids == (0, 3, 6, 9)
    assert nearest_seen(p, fits, 3, (0, 3, 6, 9)) == (2, 4, 7, 8)  # 3: 2 and 4 tie, the later wins; 0: 1 is dropped
    t = seen_target(p, fits, 3)
    assert t.key == "seen-k3" and t.frame_ids == (2, 4, 7, 8) and t.applies_to(3) and not t.applies_to(0)
    assert trained_on(p, fits, 3, t.frame_ids) == 4
    assert seen_target(p, fits, 0) is None
    labels = ["train", "test"] * 5  # the published test frames are never anyone's seen frames
    assert nearest_seen(_project(labels), fits, 0, (1, 3)) == (2, 4)
