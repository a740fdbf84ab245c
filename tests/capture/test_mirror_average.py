"""Keypoints of the image and of its mirror image, averaged where they agree."""

from __future__ import annotations

import numpy as np

from morf.capture.keypoint_layout import KEYPOINT_NAMES
from morf.capture.mirror_average import MIRROR_INDEX, mirror_average, unmirror


def _body(rng, width=200):
    pts = np.zeros((len(KEYPOINT_NAMES), 3), np.float32)
    pts[:, 0] = rng.uniform(40, width - 40, len(pts))
    pts[:, 1] = np.linspace(20, 180, len(pts))  # 160 px tall: agreement within 4 px
    pts[:, 2] = 1.0
    return pts


def _as_seen_mirrored(points, width):
    """What a perfect detector returns on ``image[:, ::-1]``: x mirrored, left and right named the other way."""
    out = points.copy()
    out[:, 0] = width - out[:, 0]
    return out[MIRROR_INDEX]


def test_the_mirror_partners_are_left_and_right_of_the_same_point():
    for i, j in enumerate(MIRROR_INDEX):
        a, b = KEYPOINT_NAMES[i], KEYPOINT_NAMES[j]
        assert MIRROR_INDEX[j] == i
        assert a == b == "nose" or {a.split("_", 1)[0], b.split("_", 1)[0]} == {"left", "right"}
        assert a.split("_", 1)[-1] == b.split("_", 1)[-1]


def test_unmirror_undoes_the_mirror_image():
    pts = _body(np.random.default_rng(0))
    np.testing.assert_allclose(unmirror(_as_seen_mirrored(pts, 200), 200), pts, atol=1e-5)
    # a pixel centre: column 0 of a 200 px image is column 199 of its mirror image
    one = np.zeros((len(KEYPOINT_NAMES), 3), np.float32)
    one[0] = (0.5, 10, 1)
    assert unmirror(_as_seen_mirrored(one, 200), 200)[0, 0] == 0.5
    assert _as_seen_mirrored(one, 200)[0, 0] == 199.5


def test_points_the_passes_agree_on_are_averaged_and_the_rest_kept():
    rng = np.random.default_rng(1)
    pts = _body(rng)
    other = pts.copy()
    other[:, 0] += 2.0  # the mirrored pass sees every point 2 px further right ...
    other[5, 0] += 30.0  # ... but the left shoulder far off (a left/right mix-up)
    other[7, 2] = 0.0  # and not the left elbow
    pts[9, 2] = 0.0  # the plain pass misses the left wrist
    out = mirror_average(pts, _as_seen_mirrored(other, 200), 200)
    moved = out[:, 0] - pts[:, 0]
    kept = [5, 7, 9]
    np.testing.assert_allclose(np.delete(moved, kept), 1.0, atol=1e-4)
    np.testing.assert_allclose(moved[kept], 0.0)
    np.testing.assert_array_equal(out[:, 1:], pts[:, 1:])  # y as both agree on it, confidence as detected


def test_morf_run_passes_no_mirror_average_on_to_ingest(tmp_path):
    """``morf run --video FILE --no-mirror-average`` ingests with the flag, and with no value after it."""
    from morf.cli.main import build_parser
    from morf.cli.run import _ingest_plan

    video = tmp_path / "clip.mp4"
    video.write_bytes(b"\0")  # the plan only checks that the file is there
    parser = build_parser()
    args = parser.parse_args(["run", str(tmp_path / "p"), "--video", str(video), "--every", "2", "--no-mirror-average"])
    assert _ingest_plan(tmp_path / "p", args).argv == ("ingest", str(tmp_path / "p"), "--video", str(video),
                                                       "--every", "2", "--no-mirror-average")
    args = parser.parse_args(["run", str(tmp_path / "p"), "--video", str(video)])
    assert "--no-mirror-average" not in _ingest_plan(tmp_path / "p", args).argv
    assert parser.parse_args(["ingest", str(tmp_path / "q"), "--video", str(video)]).mirror_average is True
    off = parser.parse_args(["ingest", str(tmp_path / "q"), "--video", str(video), "--no-mirror-average"])
    assert off.mirror_average is False
