"""People-Snapshot import on a tiny subject written in the dataset's layout."""

from __future__ import annotations

import json
import pickle

import cv2
import numpy as np
import pytest

from morf.capture.project import CaptureProject
from morf.datasets import PeopleSnapshotConfig, import_people_snapshot
from morf.datasets.people_snapshot import SPLITS
from morf.errors import InputError
from morf.io import load_npz
from tests.datasets.fakes import RunsCommand, make_people_snapshot, person_box
from tests.conftest import require

require("h5py")

SUBJECT = "tiny-casual"


@pytest.fixture
def subject(tmp_path, monkeypatch):
    monkeypatch.setitem(SPLITS, SUBJECT, {"train": (0, 7, 2), "test": (8, 11, 1)})
    return make_people_snapshot(tmp_path / "people_snapshot", SUBJECT)


def _no_detect(**kw):
    return PeopleSnapshotConfig(detect=False, **kw)


def test_train_split_frames_masks_camera(subject, tmp_path):
    res = import_people_snapshot(subject.parent, tmp_path / "proj", _no_detect(subject=SUBJECT))
    project = CaptureProject.open(tmp_path / "proj")
    ds = project.manifest["dataset"]
    assert res.num_frames == project.num_frames == 4 and ds["source_frames"] == [0, 2, 4, 6]
    assert ds["splits"] == ["train"] * 4 and ds["split_from"] == "InstantAvatar"
    for n, i in enumerate(ds["source_frames"]):
        mask = project.load_mask(n)
        x0, y0, x1, y1 = person_box(i)
        expect = np.zeros_like(mask)
        expect[y0:y1, x0:x1] = True
        assert (mask == expect).all()  # the mask of source frame i, exactly
        gray = project.load_frame(n).mean(2)
        assert gray[mask].mean() > 150 and gray[~mask].mean() < 60  # and the frame it belongs to
    cam = project.camera()
    assert (cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height) == (110.0, 112.0, 47.0, 41.0, 96, 80)
    assert np.allclose(cam.R, np.eye(3)) and np.allclose(cam.t, [0.0, 0.3, 2.5])
    kp = project.load_keypoints()
    assert not kp.detected.any() and set(kp.source) == {"none"}
    smpl = load_npz(tmp_path / "proj" / "dataset" / "smpl.npz")
    assert smpl["smpl_pose"].shape == (4, 72) and list(smpl["source_frames"]) == [0, 2, 4, 6]
    assert smpl["consensus_v_personal"].shape == (6890, 3)
    assert json.loads((tmp_path / "proj" / "dataset" / "split.json").read_text())["definition"]["test"] == [8, 11, 1]


def test_test_and_all_splits_every_and_max_frames(subject, tmp_path):
    res = import_people_snapshot(subject, tmp_path / "test", _no_detect(split="test"))
    assert CaptureProject.open(tmp_path / "test").manifest["dataset"]["source_frames"] == [8, 9, 10, 11]
    assert res.splits == {"test": 4}
    res = import_people_snapshot(subject, tmp_path / "all", _no_detect(split="all", every=3, max_frames=3))
    ds = CaptureProject.open(tmp_path / "all").manifest["dataset"]
    assert ds["source_frames"] == [0, 3, 6] and ds["splits"] == ["train", "", "train"]


def test_rotation_and_distortion(tmp_path, monkeypatch):
    monkeypatch.setitem(SPLITS, SUBJECT, {"train": (0, 11, 5), "test": (1, 1, 1)})
    folder = make_people_snapshot(tmp_path, SUBJECT, camera_k=(-0.2, 0.05, 0, 0, 0), camera_rt=(0.1, -0.2, 0.3))
    import_people_snapshot(folder, tmp_path / "proj", _no_detect())
    project = CaptureProject.open(tmp_path / "proj")
    assert np.allclose(project.camera().R, cv2.Rodrigues(np.array([0.1, -0.2, 0.3]))[0])
    assert project.manifest["dataset"]["undistorted"]
    for n in range(project.num_frames):  # frame and mask were undistorted alike
        mask, gray = project.load_mask(n), project.load_frame(n).mean(2)
        assert mask.sum() > 100 and gray[mask].mean() > 150 and gray[~mask].mean() < 60


def test_subject_without_split_needs_all(tmp_path):
    folder = make_people_snapshot(tmp_path, "someone-new", n=4)
    with pytest.raises(InputError, match="no published train/test split; use --split all"):
        import_people_snapshot(folder, tmp_path / "proj", _no_detect())
    res = import_people_snapshot(folder, tmp_path / "proj", _no_detect(split="all"))
    assert res.num_frames == 4 and res.splits == {"": 4}


def test_missing_and_malicious_files(subject, tmp_path):
    (subject / "masks.hdf5").unlink()
    with pytest.raises(InputError, match="masks.hdf5"):
        import_people_snapshot(subject, tmp_path / "proj", _no_detect())
    marker = tmp_path / "ran"
    (subject / "camera.pkl").write_bytes(pickle.dumps({"camera_f": RunsCommand(marker)}, protocol=2))
    with pytest.raises(InputError, match="refused to load .*camera.pkl"):
        import_people_snapshot(subject, tmp_path / "proj", _no_detect())
    assert not marker.exists() and not (tmp_path / "proj").exists()
    (subject / "camera.pkl").unlink()
    with pytest.raises(InputError, match="camera.pkl"):
        import_people_snapshot(subject, tmp_path / "proj", _no_detect())
    with pytest.raises(InputError, match="subject folder not found"):
        import_people_snapshot(subject.parent, tmp_path / "proj", _no_detect(subject="nobody"))


def test_malicious_consensus_is_skipped_not_run(subject, tmp_path):
    marker = tmp_path / "ran"
    (subject / "consensus.pkl").write_bytes(pickle.dumps({"betas": RunsCommand(marker)}))
    res = import_people_snapshot(subject, tmp_path / "proj", _no_detect())
    assert not marker.exists() and any("consensus.pkl" in w for w in res.warnings)


def test_mediapipe_runs_on_the_masked_crop(subject, tmp_path):
    require("mediapipe")  # scripts/install.sh installs it
    # MediaPipe runs on every imported frame; the test subject's boxes are no person, so nothing can be
    # fitted: the import ends with the error and leaves no project behind
    with pytest.raises(InputError, match="MediaPipe found no person in any of the 2 imported frames"):
        import_people_snapshot(subject, tmp_path / "proj", PeopleSnapshotConfig(max_frames=2))
    assert not (tmp_path / "proj").exists()
