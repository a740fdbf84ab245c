"""Face and hand landmarks: the layouts' anchors, the stored file, the OpenPose fallback, the crops,
and MediaPipe on the real sample (skipped when ../shared/data is absent)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from morf.capture.landmarks_detect import crop_square, hand_square, head_square
from morf.capture.landmarks_face_hands import (IBUG_FACE_ANCHORS, MEDIAPIPE_FACE_ANCHORS, FaceHandLandmarks,
                                               face_anchors, load_landmarks, save_landmarks)
from morf.errors import ProjectError


def _face(points: int, n: int = 2, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    f = np.concatenate([rng.uniform(0, 100, (n, points, 2)), np.ones((n, points, 1))], -1).astype(np.float32)
    return f


@pytest.mark.parametrize("points, table", [(478, MEDIAPIPE_FACE_ANCHORS), (70, IBUG_FACE_ANCHORS)])
def test_face_anchors_average_their_points_in_either_layout(points, table):
    face = _face(points)
    face[1, table[3][0], 2] = 0.2  # a weak mouth point weakens the mouth anchor
    a = face_anchors(face)
    assert a.shape == (2, 5, 3)
    for k, idx in enumerate(table):
        np.testing.assert_allclose(a[:, k, :2], face[:, list(idx), :2].mean(1), rtol=1e-6)
    assert a[1, 3, 2] == pytest.approx(0.2) and a[0, 3, 2] == 1
    with pytest.raises(ValueError, match="478 or 70"):
        face_anchors(_face(68))


def _project(tmp_path: Path, n: int = 2):
    return SimpleNamespace(root=tmp_path, num_frames=n)


def test_stored_landmarks_read_back_and_openpose_counts_as_the_same_evidence(tmp_path):
    project = _project(tmp_path)
    assert load_landmarks(project) is None
    from morf.io import save_npz

    hands = _face(21)
    save_npz(tmp_path / "keypoints_hands_face.npz", hand_left=hands, hand_right=hands + 1, face=_face(70),
             present=np.ones(2, bool))
    op = load_landmarks(project)
    assert op.source == "openpose" and op.face_anchors().shape == (2, 5, 3)
    np.testing.assert_array_equal(op.hand_right, hands + 1)
    lm = FaceHandLandmarks(_face(478), hands, hands * 2, "mediapipe")
    save_landmarks(tmp_path, lm)
    back = load_landmarks(project)  # the detected landmarks come first
    assert back.source == "mediapipe"
    np.testing.assert_array_equal(back.face, lm.face)
    np.testing.assert_array_equal(back.hand_right, hands * 2)
    with pytest.raises(ProjectError, match="of 2 frames for 3"):
        load_landmarks(_project(tmp_path, 3))


def test_crops_map_back_to_frame_pixels():
    body = np.zeros((23, 3), np.float32)
    body[[0, 1, 2, 3, 4], :2] = [[100, 50], [95, 45], [105, 45], [88, 48], [112, 48]]
    body[[5, 6], :2] = [[70, 90], [130, 90]]
    body[:7, 2] = 0.9
    cx, cy, side = head_square(body)
    assert (cx, cy) == pytest.approx((100, 47.2)) and side == pytest.approx(72)  # 1.2 shoulder widths
    assert hand_square(body, "left") is None  # no wrist, no elbow
    body[[7, 9], :] = [[60, 130, 0.9], [60, 160, 0.9]]
    assert hand_square(body, "left") == pytest.approx((60, 170, 45))
    img = np.zeros((200, 200, 3), np.uint8)
    cv2.circle(img, (103, 40), 2, (255, 255, 255), -1)
    crop, x0, y0, scale = crop_square(img, (cx, cy, side), 256)
    ys, xs = np.nonzero(crop[..., 0] > 128)
    back = np.array([xs.mean() + 0.5, ys.mean() + 0.5]) * scale + [x0, y0]
    assert back == pytest.approx([103.5, 40.5], abs=0.3)  # the dot's centre, in MoRF's pixel centres


def test_mediapipe_finds_the_face_and_both_hands_of_the_real_sample(shared_data):
    from tests.conftest import require

    require("mediapipe")
    from morf.capture.detect_mediapipe import MediaPipeDetector
    from morf.capture.landmarks_detect import FaceHandsDetector

    path = shared_data / "images" / "ryota.png"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    rgb = cv2.imread(str(path))[:, :, ::-1].copy()
    with MediaPipeDetector() as det:
        body = det.detect(rgb).points
    with FaceHandsDetector() as fh:
        face, left, right = fh.detect(rgb, body)
    assert face.shape == (478, 3) and (face[:, 2] == 1).all()
    a = face_anchors(face[None])[0]
    # the pupils lie near the pose model's eyes (within 8 px: its eyes are coarser), the right eye on the image's left
    assert np.linalg.norm(a[0, :2] - body[2, :2]) < 8 and np.linalg.norm(a[1, :2] - body[1, :2]) < 8
    assert a[0, 0] < a[2, 0] < a[1, 0] and a[2, 1] < a[3, 1] < a[4, 1]  # eyes, nose, mouth, chin in order
    for hand, wrist in ((left, body[9]), (right, body[10])):
        assert hand[0, 2] > 0.5 and np.linalg.norm(hand[0, :2] - wrist[:2]) < 12
        assert np.linalg.norm(hand[12, :2] - hand[0, :2]) > 10  # the middle fingertip away from the wrist


def test_project_landmarks_are_stored_beside_the_keypoints(shared_data, tmp_path):
    from tests.conftest import require

    require("mediapipe")
    from morf.capture.landmarks_detect import detect_project_landmarks
    from morf.capture.landmarks_face_hands import LANDMARKS_FILE
    from morf.capture.project import CaptureProject
    from morf.cli.main import main

    path = shared_data / "images" / "ryota.png"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    assert main(["ingest", str(tmp_path / "p"), "--frames", str(path)]) == 0
    project = CaptureProject.open(tmp_path / "p")
    lm = detect_project_landmarks(project)
    from morf.io.lock import lock_path

    assert (project.root / LANDMARKS_FILE).is_file()
    assert lock_path(project.root, "landmarks").stat().st_size == 0  # given back: a free lock names no holder
    back = load_landmarks(project)
    assert back.source == "mediapipe" and back.num_frames == 1
    np.testing.assert_array_equal(back.face, lm.face)
    assert back.face[0, :, 2].min() == 1 and back.hand_left[0, 0, 2] > 0.5 and back.hand_right[0, 0, 2] > 0.5
