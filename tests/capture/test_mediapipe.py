"""MediaPipe detection and the real samples in ../shared/data (skipped when absent)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from morf.capture.detect_mediapipe import Detection, MediaPipeDetector
from morf.capture.keypoint_layout import KEYPOINT_NAMES
from morf.capture.project import CaptureProject
from morf.cli.main import main
from tests.conftest import require

require("mediapipe")


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


def test_mirror_average_through_ingest(shared_data, tmp_path, capsys):
    """``morf ingest`` (mirror average on by default) against ``--no-mirror-average``: the keypoints
    are the mean of the plain and the mirrored pass where they agree, so they move a little from
    the plain detection and no further than the agreement tolerance; the manifest says so."""
    from morf.capture.mirror_average import AGREE, MIN_AGREE_PX, mirror_average

    image = shared_data / "images" / "ryota.png"
    rc, _, err = ingest(capsys, tmp_path / "plain", "--frames", image, "--no-mirror-average")
    assert rc == 0, err
    rc, _, err = ingest(capsys, tmp_path / "mirror", "--frames", image)
    assert rc == 0, err
    plain, mirrored = (CaptureProject.open(tmp_path / n) for n in ("plain", "mirror"))
    assert mirrored.manifest["ingest"]["keypoints_mirror_average"] is True
    assert plain.manifest["ingest"]["keypoints_mirror_average"] is False
    a, b = plain.load_keypoints().points[0], mirrored.load_keypoints().points[0]
    seen = a[:, 2] > 0
    moved = np.linalg.norm(a[:, :2] - b[:, :2], axis=-1)[seen]
    tol = max(MIN_AGREE_PX, AGREE * np.ptp(a[seen, 1]))
    assert 0 < moved.max() <= tol / 2 + 1e-3  # half-way to a point that agreed within the tolerance
    assert (moved > 0).sum() >= 10  # most points were seen alike in both passes
    # the same frame detected by hand gives the same points
    frame = plain.load_frame(0)
    with MediaPipeDetector() as det:
        one, other = det.detect(frame), det.detect(np.ascontiguousarray(frame[:, ::-1]))
    np.testing.assert_allclose(mirror_average(one.points, other.points, frame.shape[1]), b, atol=0.05)
