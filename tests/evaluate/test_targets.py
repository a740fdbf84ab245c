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


def test_holdout_target_is_every_kth_usable_frame():
    p = _project(["train"] * 7, dropped=(1,))
    t = holdout_target(p, _fits(7), 2)
    assert t.frame_ids == (0, 3, 5) and t.holdout == 2 and t.applies_to(2) and not t.applies_to(3)
    assert holdout_target(p, _fits(7), 0) is None
    assert [ordinal(k) for k in (2, 3, 4, 11, 21, 22)] == ["2nd", "3rd", "4th", "11th", "21st", "22nd"]


def test_nearest_seen_frames_are_training_frames_next_to_the_held_out_ones():
    p = _project(["train"] * 10, dropped=(1,))  # usable 0 2 3 4 5 6 7 8 9; hold-out 3 keeps 0 4 7 out
    fits = _fits(10)
    assert holdout_target(p, fits, 3).frame_ids == (0, 4, 7)
    assert nearest_seen(p, fits, 3, (0, 4, 7)) == (2, 5, 8)  # 4: 3 and 5 tie, the later wins; 0: frame 1 is dropped
    t = seen_target(p, fits, 3)
    assert t.key == "seen-k3" and t.frame_ids == (2, 5, 8) and t.applies_to(3) and not t.applies_to(0)
    assert trained_on(p, fits, 3, t.frame_ids) == 3
    assert seen_target(p, fits, 0) is None
    labels = ["train", "test"] * 5  # the published test frames are never anyone's seen frames
    assert nearest_seen(_project(labels), fits, 0, (1, 3)) == (2, 4)
