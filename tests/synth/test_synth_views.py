"""Sparse synthetic captures: a few views of the turn, 45 degrees apart for 8, with their times
or as an unordered photo set."""

import numpy as np
import pytest

from morf.capture.project import CaptureProject
from morf.errors import InputError
from morf.synth import make_synthetic_capture, synth_config
from morf.synth.ground_truth import load_ground_truth
from morf.synth.motion import capture_motion, view_frames


def test_views_are_spread_evenly_over_the_turn(body_model):
    m = capture_motion(body_model.bone_names, 240, np.random.default_rng(0))
    idx = view_frames(m.yaw, m.phase, 8, 360.0)
    assert len(idx) == 8 and (np.diff(idx) > 0).all() and (m.phase[idx] == "turn").all()
    assert np.degrees(m.yaw[idx]) == pytest.approx(np.arange(8) * 45.0, abs=1.5)
    half = view_frames(m.yaw, m.phase, 3, 180.0)  # a partial turn keeps both of its ends
    assert np.degrees(m.yaw[half]) == pytest.approx([0.0, 90.0, 180.0], abs=4.0)


def test_views_are_checked():
    with pytest.raises(InputError, match="views"):
        synth_config("tiny", views=13)
    with pytest.raises(InputError, match="photo_set needs views"):
        synth_config("tiny", photo_set=True)


@pytest.mark.gl
@pytest.mark.parametrize("photo_set", [False, True])
def test_a_sparse_capture_keeps_views_with_their_truth(tmp_path, body_model, gl, photo_set):
    cfg = synth_config("tiny", frames=40, views=4, photo_set=photo_set, holdout_frames=1)
    p = make_synthetic_capture(tmp_path / "p", cfg, model=body_model)
    p = CaptureProject.open(p.root)
    assert p.num_frames == 4 and len(list((p.root / "frames").iterdir())) == 4
    gt = load_ground_truth(p, require=("yaw", "keypoints_true", "slide_grid"))
    assert np.degrees(gt.yaw) == pytest.approx([0, 90, 180, 270], abs=10.0)  # 32 turn frames: 11 degrees apart
    assert gt.keypoints_true.shape[0] == 4 and gt.slide_grid.shape[0] == 4
    if photo_set:
        assert p.unordered_views and p.fps is None and p.frame_times() is None
    else:  # the views keep the times they had in the clip: several frames apart, not 33 ms
        assert not p.unordered_views
        assert np.diff(p.frame_times()).min() > 5 / cfg.fps
