"""`morf ingest --video` keeps a clip's real frame times (variable frame rate) and turns sideways
clips upright from their rotation metadata. The clips are written with PyAV (FFmpeg's libraries)."""

from __future__ import annotations

import numpy as np
import pytest

from morf.capture.project import CaptureProject
from morf.capture.video_pyav import quarter_turns, upright
from morf.cli.main import main
from morf.errors import ProjectError
from capture_helpers import frame_image, write_masks, write_openpose, write_timed_video
from tests.conftest import require

# irregular gaps from 20 to 150 ms, as a phone in dim light records
TIMES = [0.0, 0.033, 0.1, 0.12, 0.25, 0.3, 0.45, 0.47]


def ingest(capsys, root, video, n, w=64, h=48, *extra):
    kp = write_openpose(root.parent / f"{root.name}_kp", n, [(10, 8, 30, 40)])
    masks = write_masks(root.parent / f"{root.name}_masks", n, w, h)
    rc = main(["ingest", str(root), "--video", str(video), "--keypoints", str(kp), "--masks", str(masks), *extra])
    out = capsys.readouterr()
    assert rc == 0, out.err
    return out.out + out.err


def test_upright_turns_by_quarter_turns():
    a = np.arange(6).reshape(2, 3)
    assert quarter_turns(-90) == 3 and quarter_turns(90) == 1 and quarter_turns(180) == quarter_turns(-180) == 2
    assert quarter_turns(-89.9) == 3 and quarter_turns(0) == 0
    assert upright(a, 0) is a
    # -90 (a phone's rotate=90): the stored frame is turned clockwise, so its top-left goes top-right
    assert upright(a, -90).tolist() == [[3, 0], [4, 1], [5, 2]]
    assert upright(a, 90).tolist() == [[2, 5], [1, 4], [0, 3]]
    assert upright(a, 180).tolist() == [[5, 4, 3], [2, 1, 0]]


def test_variable_frame_rate_times_are_recorded(tmp_path, capsys):
    require("av")
    video = write_timed_video(tmp_path / "vfr.mp4", [frame_image(i) for i in range(len(TIMES))], TIMES)
    root = tmp_path / "p"
    said = ingest(capsys, root, video, len(TIMES))
    assert "variable frame rate" in said
    p = CaptureProject.open(root)
    assert p.num_frames == len(TIMES)
    assert p.frame_times() == pytest.approx(TIMES, abs=1e-3)
    timing = p.manifest["ingest"]["timing"]
    assert timing["source"] == "timestamps" and timing["variable"] is True
    assert timing["interval_ms"][0] == pytest.approx(20, abs=1)
    assert timing["interval_ms"][2] == pytest.approx(150, abs=1)
    assert p.manifest["ingest"]["decoder"] == "pyav"

    # every 2nd frame keeps the kept frames' own times
    root2 = tmp_path / "p2"
    ingest(capsys, root2, video, len(TIMES), 64, 48, "--every", "2")
    assert CaptureProject.open(root2).frame_times() == pytest.approx(TIMES[::2], abs=1e-3)

    # a frame rate given by the user overrides the video's times
    root3 = tmp_path / "p3"
    ingest(capsys, root3, video, len(TIMES), 64, 48, "--fps", "20")
    p3 = CaptureProject.open(root3)
    assert "frame_times" not in p3.manifest and p3.manifest["ingest"]["timing"]["source"] == "fps"
    assert p3.frame_times() == pytest.approx(np.arange(len(TIMES)) / 20)


def test_rotation_metadata_turns_frames_upright(tmp_path, capsys):
    require("av")
    stored = [frame_image(i) for i in range(4)]  # 64x48, a white block left of centre
    video = write_timed_video(tmp_path / "phone.mp4", stored, [i / 30 for i in range(4)], rotation=-90)
    root = tmp_path / "p"
    said = ingest(capsys, root, video, 4, 48, 64)  # masks in the upright size
    assert "turning frames 90 degrees clockwise" in said
    p = CaptureProject.open(root)
    assert p.image_size == (48, 64)
    assert p.manifest["ingest"]["rotation"] == -90
    for i in range(4):
        expected = np.rot90(stored[i][..., ::-1], -1)  # turned clockwise, RGB
        got = p.load_frame(i)
        assert got.shape == expected.shape == (64, 48, 3)
        assert np.abs(got.astype(int) - expected).mean() < 4  # H.264 at crf 10: close, not exact
    assert p.frame_times() == pytest.approx([i / 30 for i in range(4)], abs=1e-3)
    assert p.manifest["ingest"]["timing"]["variable"] is False


def test_projects_without_frame_times_still_load(tmp_path):
    old = CaptureProject.create(tmp_path / "old", num_frames=3, width=64, height=48, fps=10.0, source={"kind": "video"})
    assert "frame_times" not in old.manifest
    assert CaptureProject.open(old.root).frame_times() == pytest.approx([0.0, 0.1, 0.2])
    images = CaptureProject.create(tmp_path / "img", num_frames=2, width=64, height=48, fps=None,
                                   source={"kind": "images"})
    assert images.frame_times() is None
    old.update_manifest(frame_times=[0.0, 0.1])  # wrong length
    with pytest.raises(ProjectError, match="frame_times"):
        CaptureProject.open(old.root).frame_times()


def test_without_pyav_opencv_decodes_as_before(tmp_path, capsys, monkeypatch):
    require("av")  # to write the clip
    stored = [frame_image(i) for i in range(4)]
    video = write_timed_video(tmp_path / "phone.mp4", stored, [i / 30 for i in range(4)], rotation=-90)
    monkeypatch.setattr("morf.capture.video_pyav.pyav_available", lambda: False)
    root = tmp_path / "p"
    ingest(capsys, root, video, 4, 48, 64)
    p = CaptureProject.open(root)
    assert p.manifest["ingest"]["decoder"] == "opencv" and "frame_times" not in p.manifest
    assert p.frame_times() == pytest.approx(np.arange(4) / p.fps)
    # OpenCV's FFmpeg backend turns the frames upright itself
    assert p.image_size == (48, 64) and p.manifest["ingest"]["rotation"] == -90
    assert np.abs(p.load_frame(0).astype(int) - np.rot90(stored[0][..., ::-1], -1)).mean() < 4


def test_webm_without_a_frame_count_is_read_whole(tmp_path, capsys):
    """WebM states no frame count: the estimate from its duration must not make a whole file look cut."""
    require("av")
    from morf.playback.video_sink import VideoSink

    sink = VideoSink(tmp_path / "clip.webm", 24.0, (64, 48))
    for i in range(6):
        sink.write(frame_image(i)[..., ::-1].copy())
    sink.close()
    root = tmp_path / "p"
    said = ingest(capsys, root, tmp_path / "clip.webm", 6)
    assert "warning" not in said
    p = CaptureProject.open(root)
    assert p.num_frames == 6 and not p.manifest["ingest"]["warnings"]
    assert p.frame_times() == pytest.approx(np.arange(6) / 24, abs=1e-3)
