"""The ground truth files of a synthetic capture: what the writer stores the readers return, and a
missing file or array is reported in one clear line (no rendering, so no OpenGL needed)."""

import numpy as np
import pytest

from morf.camera import PinholeCamera
from morf.capture.project import CaptureProject
from morf.errors import InputError, ProjectError
from morf.io import load_npz, save_npz
from morf.synth.ground_truth import (GroundTruth, HoldoutSequence, has_ground_truth, has_holdout, load_ground_truth,
                                     load_holdout, read_holdout_frame, read_holdout_mask, save_ground_truth,
                                     save_holdout, write_holdout_images)


def _project(tmp_path) -> CaptureProject:
    return CaptureProject.create(tmp_path / "cap", num_frames=3, width=32, height=24, fps=10.0,
                                 source={"kind": "synthetic"})


def _truth(n: int = 3) -> GroundTruth:
    rng = np.random.default_rng(0)
    return GroundTruth(rotvecs=rng.normal(size=(n, 104, 3)).astype(np.float32),
                       transl=rng.normal(size=(n, 3)).astype(np.float32), shape=np.ones((1, 6), np.float32),
                       yaw=np.linspace(0, 1, n), phase=np.array(["turn"] * n), corrupted=np.array([False, True, False]),
                       keypoints_true=np.zeros((n, 23, 3), np.float32))


def _camera() -> PinholeCamera:
    return PinholeCamera(40.0, 41.0, 16.0, 12.0, 32, 24, np.eye(3), np.array([0.0, 0.1, 2.5]))


def test_ground_truth_round_trip(tmp_path):
    p = _project(tmp_path)
    assert not has_ground_truth(p) and not has_ground_truth(p.root)
    truth = _truth()
    save_ground_truth(p, truth)
    assert has_ground_truth(p) and has_ground_truth(str(p.root)) and p.ground_truth_path.is_file()
    assert "valid" not in load_npz(p.ground_truth_path)  # None fields are left out of the file
    back = load_ground_truth(p.root, require=("yaw", "corrupted"))
    for name in ("rotvecs", "transl", "shape", "yaw", "phase", "corrupted", "keypoints_true"):
        stored = getattr(back, name)
        np.testing.assert_array_equal(stored, getattr(truth, name))
        assert stored.dtype == getattr(truth, name).dtype  # returned as stored
    assert back.slide_grid is None and back.num_frames == 3
    assert back.valid.dtype == bool and back.valid.all()  # every frame when the file does not say


def test_missing_ground_truth_is_one_clear_line(tmp_path):
    p = _project(tmp_path)
    with pytest.raises(InputError, match=r"has no ground truth \(ground_truth/gt.npz\)"):
        load_ground_truth(p)
    with pytest.raises(ProjectError):  # the handlers of a damaged project catch it too
        load_ground_truth(p.root)
    with pytest.raises(InputError, match=r"has no hold-out sequence \(ground_truth/holdout.npz\)"):
        load_holdout(p)


def test_a_lacking_array_is_named(tmp_path):
    p = _project(tmp_path)
    save_npz(p.ground_truth_path, rotvecs=np.zeros((2, 104, 3)), transl=np.zeros((2, 3)))
    with pytest.raises(InputError, match=r"gt.npz: no 'shape' array"):
        load_ground_truth(p)
    save_ground_truth(p, _truth())
    with pytest.raises(InputError, match=r"no 'slide_grid' array"):
        load_ground_truth(p, require=("slide_grid",))
    with pytest.raises(ValueError):  # a misspelt field is a programming error, not a damaged file
        load_ground_truth(p, require=("slide_gird",))


def test_holdout_round_trip_with_camera_and_images(tmp_path):
    p = _project(tmp_path)
    assert not has_holdout(p)
    rng = np.random.default_rng(1)
    seq = HoldoutSequence(rotvecs=rng.normal(size=(2, 104, 3)).astype(np.float32), transl=np.zeros((2, 3), np.float32),
                          shape=np.ones((1, 6), np.float32), phase=np.array(["arms", "step"]), camera=_camera())
    rgb = rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)
    mask = np.zeros((24, 32), bool)
    mask[5:20, 10:20] = True
    for j in range(2):
        write_holdout_images(p, j, rgb, mask)
    save_holdout(p, seq)
    assert has_holdout(p.root) and p.holdout_frame_path(1).is_file() and p.holdout_mask_path(1).is_file()
    back = load_holdout(p, require=("shape", "camera"))
    assert back.num_frames == 2 and back.yaw is None and back.keypoints is None
    np.testing.assert_array_equal(back.rotvecs, seq.rotvecs)
    np.testing.assert_array_equal(back.phase, seq.phase)
    cam = back.camera
    assert (cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height) == (40.0, 41.0, 16.0, 12.0, 32, 24)
    np.testing.assert_array_equal(cam.t, _camera().t)
    np.testing.assert_array_equal(read_holdout_frame(p, 1), rgb)
    stored = read_holdout_mask(p, 0)
    assert stored.dtype == np.uint8 and set(np.unique(stored)) == {0, 255}
    np.testing.assert_array_equal(stored > 127, mask)


def test_holdout_without_or_with_part_of_a_camera(tmp_path):
    p = _project(tmp_path)
    save_holdout(p, HoldoutSequence(rotvecs=np.zeros((0, 104, 3)), transl=np.zeros((0, 3))))
    back = load_holdout(p)
    assert back.camera is None and back.num_frames == 0  # the project's camera then applies
    with pytest.raises(InputError, match="no 'K' array of its camera"):
        load_holdout(p, require=("camera",))
    save_npz(p.holdout_path, rotvecs=np.zeros((1, 104, 3)), transl=np.zeros((1, 3)), K=np.eye(3))
    with pytest.raises(InputError, match="no 'R' array of its camera"):
        load_holdout(p)


def test_training_and_eval_read_through_the_owner(tmp_path):
    from morf.evaluate.targets import novel_poses_target
    from morf.train.data import fitted_frame_offset, load_body_fits

    p = _project(tmp_path)
    assert novel_poses_target(p) is None
    save_ground_truth(p, _truth())
    fits = load_body_fits(p, "auto")  # no fits: the ground truth
    assert fits.source == "ground-truth" and fits.valid.all() and fits.rotvecs.shape == (3, 104, 3)
    np.testing.assert_array_equal(fitted_frame_offset(p, fits), np.zeros(3, np.float32))
    save_holdout(p, HoldoutSequence(rotvecs=np.zeros((4, 104, 3)), transl=np.zeros((4, 3))))
    assert novel_poses_target(p).frame_ids == (0, 1, 2, 3)
