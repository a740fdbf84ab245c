"""MediaPipe detection and the real samples in ../shared/data (skipped when absent)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from morf.capture.detect_mediapipe import Detection, MediaPipeDetector
from morf.capture.keypoint_layout import KEYPOINT_NAMES
from morf.capture.project import CaptureProject
from morf.cli.main import main

pytest.importorskip("mediapipe")


def ingest(capsys, *argv) -> tuple[int, str, str]:
    rc = main(["ingest", *map(str, argv)])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_detector_api_on_an_empty_image():
    with MediaPipeDetector() as det:
        d = det.detect(np.full((96, 128, 3), 30, np.uint8))
    assert isinstance(d, Detection) and not d.found
    assert d.points.shape == (23, 3) and d.points.dtype == np.float32
    assert d.mask.shape == (96, 128) and d.mask.dtype == np.float32
    with pytest.raises(ValueError):
        MediaPipeDetector().detect(np.zeros((4, 4), np.uint8))


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def test_real_image(shared_data, tmp_path, capsys):
    image = shared_data / "images" / "ryota.png"
    truth = cv2.imread(str(shared_data / "images" / "ryota_mask.png"), cv2.IMREAD_GRAYSCALE) > 127
    rc, out, err = ingest(capsys, tmp_path / "p", "--frames", image)
    assert rc == 0, err
    p = CaptureProject.open(tmp_path / "p")
    kp = p.load_keypoints()
    assert p.num_frames == 1 and kp.detected[0] and kp.source[0] == "mediapipe"
    pts = {n: kp.points[0, i] for i, n in enumerate(KEYPOINT_NAMES)}
    assert pts["nose"][1] < pts["left_hip"][1] < pts["left_knee"][1] < pts["left_ankle"][1]
    assert pts["left_shoulder"][0] > pts["right_shoulder"][0]  # a front view: the person's left is image right
    assert _iou(p.load_mask(0), truth) > 0.9

    rc, out, err = ingest(capsys, tmp_path / "q", "--frames", image, "--masks", shared_data / "images" / "ryota_mask.png")
    assert rc == 0, err
    q = CaptureProject.open(tmp_path / "q")
    assert (q.load_mask(0) == truth).all()
    assert q.load_keypoints().detected[0]
    assert q.manifest["ingest"]["masks_from"] == "import"


def test_two_people_video_follows_the_largest(shared_data, tmp_path, capsys):
    video = shared_data / "video" / "two_people_outdoor.mp4"
    rc, out, err = ingest(capsys, tmp_path / "p", "--video", video, "--every", "30", "--max-frames", "4")
    assert rc == 0, err
    assert "people seen; following the largest" in out
    p = CaptureProject.open(tmp_path / "p")
    assert p.manifest["ingest"]["people"]["seen"] >= 2
    assert p.manifest["ingest"]["source_frames"] == [0, 30, 60, 90]
    kp = p.load_keypoints()
    assert kp.detected.all()
    # the man standing on the cabinet (upper left) is the first and largest in view; the woman
    # walking across the lawn below must never be taken instead
    for i in range(4):
        seen = kp.points[i, kp.points[i, :, 2] > 0.5]
        cx, cy = seen[:, 0].mean(), seen[:, 1].mean()
        assert 450 < cx < 850 and cy < 500, (i, cx, cy)
        ys, xs = np.nonzero(p.load_mask(i))
        assert ys.max() < 560 and xs.min() > 400, i  # no pixels of the woman below the cabinet
