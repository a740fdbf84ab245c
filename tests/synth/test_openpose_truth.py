"""A synthetic photo set written as OpenPose JSON from the truth reads back through the real
OpenPose import: body points on the projected truth, the face only where it faces the camera,
both hands beyond their wrists."""

import numpy as np
import pytest

from morf.capture.openpose import read_openpose_json
from morf.capture.project import CaptureProject
from morf.synth import make_synthetic_capture, synth_config
from morf.synth.ground_truth import load_ground_truth
from morf.synth.openpose_truth import _face_template, landmark_points, write_openpose_views


def test_face_template_is_the_70_point_layout():
    t = _face_template(-0.6, -1.0, -1.6)
    assert t.shape == (70, 2)
    assert t[8, 1] == pytest.approx(-1.6) and t[30, 1] == pytest.approx(-0.6)  # chin, nose tip
    assert (t[36:42, 0] < 0).all() and (t[42:48, 0] > 0).all()  # right eye on the person's right (-x)
    assert t[0, 0] < 0 < t[16, 0]


def test_landmark_points_sit_on_the_face_and_hands(body_model):
    lm = landmark_points(body_model)
    import torch

    with torch.no_grad():
        out = body_model(body_model.zero_pose(1), body_model.default_shape())
    v = out.vertices[0].numpy()
    f = v[lm.face_vertices]
    assert f[68, 0] < f[69, 0]  # the right pupil on the person's right (-X)
    assert f[8, 2] < f[57, 2] < f[30, 2] < f[68, 2]  # chin below the mouth below the nose tip below the eyes
    assert f[30, 1] < f[0, 1] and f[30, 1] < f[16, 1]  # the nose tip in front of the jaw's ends
    assert f[36, 0] < f[39, 0] < 0 < f[42, 0] < f[45, 0]  # eye corners: right outer, right inner, left inner, left outer
    # the eye contours' means sit on the pupils the fit reads as the eyes (within 2 mm)
    assert np.abs(f[36:42].mean(0) - f[68]).max() < 0.002 and np.abs(f[42:48].mean(0) - f[69]).max() < 0.002
    tips = v[lm.hand_tips["L"]]
    wrist = out.joints[0, lm.hand_joints["L"][0]].numpy()
    assert (np.linalg.norm(tips - wrist, axis=1) > 0.05).all() and (tips[:, 0] > 0).all()


@pytest.mark.gl
def test_written_views_read_back_as_openpose(tmp_path, body_model, gl):
    cfg = synth_config("tiny", frames=40, views=4, photo_set=True, holdout_frames=1, size=256)
    p = CaptureProject.open(make_synthetic_capture(tmp_path / "p", cfg, model=body_model).root)
    paths = write_openpose_views(p, tmp_path / "photos", body_model, noise_px=0.0, landmark_noise_px=0.0)
    assert [q.name for q in paths] == [f"view_{i:03d}.jpg" for i in range(4)]
    gt = load_ground_truth(p, require=("keypoints_true", "yaw"))
    for i in range(4):
        (person,) = read_openpose_json(tmp_path / "photos" / f"view_{i:03d}_keypoints.json")
        assert person.layout == "BODY_25" and person.face.shape == (70, 3) and person.hand_left.shape == (21, 3)
        seen = person.body[:, 2] > 0
        err = np.linalg.norm(person.body[seen, :2] - gt.keypoints_true[i, seen, :2], axis=1)
        assert err.max() < 0.01
        front = abs(np.degrees(gt.yaw[i])) < 30
        back = abs(np.degrees(gt.yaw[i]) - 180) < 30
        if front:
            assert (person.face[:, 2] > 0).all() and person.body[0, 2] > 0
        if back:  # the back of the head: no face, no nose or eyes; the ears are seen
            assert (person.face[:, 2] == 0).all() and (person.body[:3, 2] == 0).all() and (person.body[3:5, 2] > 0).all()
        wrist = person.body[9, :2]
        assert np.linalg.norm(person.hand_left[0, :2] - wrist) < 3.0  # the wrist bone head, beside COCO's wrist
