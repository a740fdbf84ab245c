"""A tiny synthetic capture is a valid project whose ground truth explains its images."""

import json
from dataclasses import fields

import cv2
import numpy as np
import pytest
import torch

from morf.body import BodyPose
from morf.body.render_mesh import render_mesh_for
from morf.camera import PinholeCamera
from morf.capture.project import CaptureProject
from morf.io import load_npz, read_image
from morf.synth import make_synthetic_capture, synth_config
from morf.synth.ground_truth import GroundTruth, load_ground_truth, load_holdout, read_holdout_frame, read_holdout_mask

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def tiny(tmp_path_factory, body_model, gl):
    root = tmp_path_factory.mktemp("synth") / "tiny"
    return make_synthetic_capture(root, synth_config("tiny", corrupt=0.25), model=body_model)


def test_tiny_preset_builds_a_valid_project(tiny):
    p = CaptureProject.open(tiny.root)
    N = 12
    assert p.num_frames == N and p.image_size == (128, 128) and p.is_synthetic
    for i in range(N):
        assert p.load_frame(i).shape == (128, 128, 3)
        assert p.load_mask(i).any()
    kp = p.load_keypoints()
    assert kp.points.shape == (N, 23, 3) and kp.detected.all()
    assert set(kp.source) == {"ground_truth"}  # the tiny preset runs no detector
    every = tuple(f.name for f in fields(GroundTruth) if f.name != "valid")  # valid is optional: every frame when absent
    gt = load_ground_truth(p, require=every)  # the capture writes every array of the format
    assert set(load_npz(p.ground_truth_path)) == set(every)
    assert gt.rotvecs.shape == (N, 104, 3) and gt.transl.shape == (N, 3) and gt.shape.shape == (1, 6)
    assert gt.corrupted.shape == (N,) and gt.slide_coeffs.shape[0] == N and gt.valid.all()
    assert set(gt.phase) == {"turn", "hands"}
    # the person turns all the way round
    assert gt.yaw[0] == pytest.approx(0, abs=1e-6) and gt.yaw.max() == pytest.approx(2 * np.pi, abs=1e-4)
    hold = load_holdout(p, require=("shape", "yaw", "phase", "keypoints", "camera"))
    assert hold.num_frames == 4 and hold.rotvecs.shape == (4, 104, 3)
    assert np.allclose(hold.camera.K, p.camera().K) and np.allclose(hold.camera.t, p.camera().t)
    for j in range(4):
        assert read_holdout_frame(p, j).shape == (128, 128, 3)
        assert (read_holdout_mask(p, j) > 127).any()
    # novel poses: no hold-out pose equals a capture pose
    d = np.abs(hold.rotvecs[:, None, 1:] - gt.rotvecs[None, :, 1:]).max(axis=(2, 3))
    assert d.min() > 0.2
    cfg = json.loads((p.ground_truth_dir / "synth_config.json").read_text())
    assert cfg["config"]["preset"] == "tiny" and cfg["config"]["corrupt"] == 0.25
    cam = PinholeCamera.from_dict(json.loads((p.ground_truth_dir / "camera.json").read_text()))
    assert np.allclose(cam.K, p.camera().K) and np.allclose(cam.R, p.camera().R)


def test_masks_match_the_projected_geometry(tiny, body_model):
    from morf.raster import rasterize_uv

    p = CaptureProject.open(tiny.root)
    gt = load_npz(p.ground_truth_path)
    cam = p.camera()
    rm = render_mesh_for(body_model)
    frames = [0, 5, 11]
    with torch.no_grad():
        out = body_model(BodyPose(torch.as_tensor(gt["rotvecs"][frames]), torch.as_tensor(gt["transl"][frames])),
                         torch.as_tensor(gt["shape"]))
    verts = rm.gather(out.vertices).numpy()
    for k, i in enumerate(frames):
        body = rasterize_uv(verts[k], rm, cam).mask
        stored_body = read_image(p.ground_truth_dir / "body_masks" / f"{i:06d}.png", grayscale=True) > 127
        assert np.array_equal(body, stored_body)  # the stored poses reproduce the body exactly
        mask = p.load_mask(i)
        # loose garments: the dressed silhouette holds the body and is larger than it
        assert (body & ~mask).sum() <= 0.02 * body.sum()
        assert mask.sum() > body.sum() and (mask & body).sum() / mask.sum() > 0.7
        # the image shows the person exactly where the mask is
        frame = p.load_frame(i).astype(int)
        background = np.all(np.abs(frame - np.array([118, 124, 130])) <= 1, axis=-1)
        near = cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # anti-aliased border
        assert background[~near].all()
        assert background[mask].mean() < 0.02
        # true torso keypoints land on the person
        kp = gt["keypoints_true"][i]
        for j in (5, 6, 11, 12):
            x, y = int(kp[j, 0]), int(kp[j, 1])
            assert mask[y, x]
        proj = cam.project(torch.as_tensor(gt["keypoints3d"][i], dtype=torch.float64)).numpy()
        np.testing.assert_allclose(proj, kp[:, :2], atol=1e-3)


def test_corrupted_frames_are_recorded(tiny):
    p = CaptureProject.open(tiny.root)
    gt = load_npz(p.ground_truth_path)
    stored = p.load_keypoints().points
    err = np.linalg.norm(stored[..., :2] - gt["keypoints_true"][..., :2], axis=-1).max(-1)  # (N,)
    bad = gt["corrupted"]
    assert bad.sum() == 3  # round(0.25 * 12)
    assert all(c != "" for c in gt["corruption"][bad]) and all(c == "" for c in gt["corruption"][~bad])
    assert err[bad].min() > 10  # a wrong pose is far from the true one ...
    assert err[~bad].max() < 6 * 1.5 + 0.5  # ... clean frames only carry the pixel noise


def test_same_seed_same_capture(tmp_path, body_model):
    small = dict(frames=3, holdout_frames=1, size=64, texture_size=128, corrupt=0.34, slide=0.01)
    a = make_synthetic_capture(tmp_path / "a", synth_config("tiny", seed=7, **small), model=body_model)
    b = make_synthetic_capture(tmp_path / "b", synth_config("tiny", seed=7, **small), model=body_model)
    c = make_synthetic_capture(tmp_path / "c", synth_config("tiny", seed=8, **small), model=body_model)
    for i in range(3):
        assert np.array_equal(a.load_frame(i), b.load_frame(i))
    assert np.array_equal(a.load_keypoints().points, b.load_keypoints().points)
    ga, gb = load_npz(a.ground_truth_path), load_npz(b.ground_truth_path)
    assert ga.keys() == gb.keys() and all(np.array_equal(ga[k], gb[k]) for k in ga)
    assert not np.array_equal(a.load_frame(1), c.load_frame(1))
    # an existing folder is refused unless asked to rebuild it
    from morf.errors import InputError

    with pytest.raises(InputError, match="not empty"):
        make_synthetic_capture(tmp_path / "a", synth_config("tiny", seed=7, **small), model=body_model)
    again = make_synthetic_capture(tmp_path / "a", synth_config("tiny", seed=7, **small), model=body_model,
                                   overwrite=True)
    assert np.array_equal(again.load_frame(2), b.load_frame(2))
