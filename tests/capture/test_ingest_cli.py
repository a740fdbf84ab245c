"""`morf ingest` end to end without MediaPipe (keypoints and masks imported), bad inputs, re-runs."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from morf.capture.project import CaptureProject
from morf.cli.main import main
from capture_helpers import write_frames, write_masks, write_openpose, write_video
from tests.conftest import require


def snapshot(root: Path) -> dict[str, str]:
    """Every file under root -> content hash (to prove a project was left untouched)."""
    return {str(p.relative_to(root)): hashlib.sha1(p.read_bytes()).hexdigest() for p in sorted(root.rglob("*")) if p.is_file()}


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    rc = main(["ingest", *map(str, argv)])
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.fixture
def inputs(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    return {
        "video": write_video(d / "clip.avi", 6),
        "kp": write_openpose(d / "kp", 6, [(10, 8, 30, 40)]),
        "masks": write_masks(d / "masks", 6),
    }


@pytest.fixture
def project(tmp_path, inputs, capsys):
    root = tmp_path / "proj"
    rc, out, err = run_cli(capsys, root, "--video", inputs["video"], "--keypoints", inputs["kp"], "--masks", inputs["masks"])
    assert rc == 0, err
    return root


def test_ingest_video_with_imported_keypoints_and_masks(project, inputs):
    p = CaptureProject.open(project)
    assert p.num_frames == 6 and p.image_size == (64, 48)
    assert p.fps == pytest.approx(10.0)
    kp = p.load_keypoints()
    assert kp.detected.all() and set(kp.source) == {"openpose"}
    # OpenPose puts pixel centres on integers, MoRF at +0.5
    raw = json.loads((inputs["kp"] / "video_000000000000_keypoints.json").read_text())["people"][0]["pose_keypoints_2d"]
    assert kp.points[0, 0, 0] == pytest.approx(raw[0] + 0.5)  # nose is BODY_25 point 0
    mask = p.load_mask(3)
    expected = cv2.imread(str(inputs["masks"] / "mask_0003.png"), 0) > 127
    assert (mask == expected).all()
    assert sorted(f.name for f in (project / "frames").iterdir()) == [f"{i:06d}.png" for i in range(6)]
    assert p.manifest["ingest"]["keypoints_from"] == "openpose"
    assert p.manifest["ingest"]["source_frames"] == list(range(6))
    assert not list(project.parent.glob(".proj.ingest-*")), "staging folder left behind"


def test_every_max_frames_resize_focal(tmp_path, inputs, capsys):
    root = tmp_path / "p2"
    rc, out, err = run_cli(capsys, root, "--video", inputs["video"], "--keypoints", inputs["kp"], "--masks", inputs["masks"],
                           "--every", "2", "--max-frames", "2", "--resize", "128", "--focal", "100")
    assert rc == 0, err
    p = CaptureProject.open(root)
    assert p.num_frames == 2 and p.image_size == (128, 96)
    assert p.manifest["ingest"]["source_frames"] == [0, 2]
    assert p.fps == pytest.approx(5.0)
    assert p.camera().fx == pytest.approx(200.0)  # focal given in source pixels, scaled with the frames
    assert p.load_mask(1).shape == (96, 128)
    raw = json.loads((inputs["kp"] / "video_000000000002_keypoints.json").read_text())["people"][0]["pose_keypoints_2d"]
    assert p.load_keypoints().points[1, 0, 0] == pytest.approx((raw[0] + 0.5) * 2)


def test_rerun_replaces_outputs(project, tmp_path, inputs, capsys):
    rc, out, err = run_cli(capsys, project, "--video", inputs["video"], "--keypoints", inputs["kp"], "--masks", inputs["masks"],
                           "--max-frames", "3")
    assert rc == 0, err
    assert "replaced" in out
    p = CaptureProject.open(project)
    assert p.num_frames == 3
    assert len(list((project / "frames").iterdir())) == 3  # no stale frames 3..5
    assert len(list((project / "masks").iterdir())) == 3
    assert p.load_keypoints().points.shape[0] == 3


def test_later_stages_need_force(project, inputs, capsys):
    (project / "fits").mkdir()
    (project / "fits" / "fits.npz").write_bytes(b"x")
    before = snapshot(project)
    rc, out, err = run_cli(capsys, project, "--video", inputs["video"], "--keypoints", inputs["kp"], "--masks", inputs["masks"])
    assert rc != 0 and "--force" in err
    assert snapshot(project) == before
    rc, out, err = run_cli(capsys, project, "--video", inputs["video"], "--keypoints", inputs["kp"], "--masks", inputs["masks"], "--force")
    assert rc == 0, err
    assert not (project / "fits").exists()
    # the replaced project's work is not deleted: it is kept beside the new one, and the note says where
    kept = [p for p in project.parent.iterdir() if p.name.startswith(f"{project.name}.replaced-")]
    assert len(kept) == 1 and (kept[0] / "fits" / "fits.npz").read_bytes() == b"x"
    assert f"kept in {kept[0]}" in err


def test_ingest_waits_for_a_writer_of_the_project(project, inputs, capsys):
    import subprocess
    import sys

    hold = "import sys, time\nfrom morf.io.lock import project_lock\nwith project_lock(sys.argv[1], 'run-x', 'morf train P'):\n" \
           "    print('held', flush=True)\n    time.sleep(60)\n"
    p = subprocess.Popen([sys.executable, "-c", hold, str(project)], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "held"
        before = snapshot(project)
        rc, out, err = run_cli(capsys, project, "--video", inputs["video"], "--keypoints", inputs["kp"], "--masks",
                               inputs["masks"], "--force")
        assert rc == 2 and f"pid {p.pid}" in err and "`morf train P`" in err, err
        assert snapshot(project) == before
    finally:
        p.kill()
        p.wait()


def _bad_inputs(tmp: Path, inputs) -> dict[str, tuple[list, str]]:
    """name -> (extra CLI args, a word the one-line message must contain)."""
    text = tmp / "notes.mp4"
    text.write_text("this is not a video\n" * 20)
    zero = tmp / "zero.avi"
    vw = cv2.VideoWriter(str(zero), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    vw.release()
    tiny = write_video(tmp / "tiny.avi", 3, 24, 16)
    huge = tmp / "huge.png"
    cv2.imwrite(str(huge), np.zeros((40, 8200, 3), np.uint8))
    bad_json = tmp / "kp_bad"
    write_openpose(bad_json, 6, [(10, 8, 30, 40)])
    (bad_json / "video_000000000003_keypoints.json").write_text('{"people": [ {"pose_keypoints_2d": [1, 2,')
    short_json = tmp / "kp_short"
    write_openpose(short_json, 6, [(10, 8, 30, 40)])
    (short_json / "video_000000000002_keypoints.json").write_text('{"people": [{"pose_keypoints_2d": [1, 2, 3]}]}')
    few_masks = write_masks(tmp / "few_masks", 4, pattern="m{i}.png")
    for f in few_masks.iterdir():  # names without numbers: only the count can pair them
        f.rename(f.with_name(f.stem.replace("0", "a").replace("1", "b").replace("2", "c").replace("3", "d") + ".png"))
    big_masks = write_masks(tmp / "big_masks", 6, 128, 96)
    empty = tmp / "empty"
    empty.mkdir()
    v = ["--video", inputs["video"]]
    return {
        "missing video": (["--video", tmp / "nope.mp4"], "not found"),
        "text as video": (["--video", text], "not a readable video"),
        "zero frames": (["--video", zero], "video"),
        "too small": (["--video", tiny], "at least 32"),
        "too large": (["--frames", huge], "--resize"),
        "empty folder": (["--frames", empty], "no images"),
        "malformed json": (v + ["--keypoints", bad_json, "--masks", inputs["masks"]], "video_000000000003_keypoints.json"),
        "short pose list": (v + ["--keypoints", short_json, "--masks", inputs["masks"]], "pose_keypoints_2d"),
        "mask count": (v + ["--keypoints", inputs["kp"], "--masks", few_masks], "no mask file for frame 4"),
        "mask size": (v + ["--keypoints", inputs["kp"], "--masks", big_masks], "128x96"),
        "bad every": (v + ["--every", "0"], "--every"),
    }


def test_bad_inputs_fail_with_one_line_and_keep_project(project, tmp_path, inputs, capsys):
    before = snapshot(project)
    for name, (args, word) in _bad_inputs(tmp_path, inputs).items():
        rc, out, err = run_cli(capsys, project, *args)
        lines = [line for line in err.splitlines() if line.strip()]
        assert rc != 0, name
        assert len(lines) == 1 and lines[0].startswith("morf ingest: error:"), f"{name}: {err!r}"
        assert word in lines[0], f"{name}: {lines[0]}"
        assert snapshot(project) == before, name
    assert not list(tmp_path.glob(".proj.ingest-*")), "staging folder left behind"


def test_not_a_project_folder_is_refused(tmp_path, inputs, capsys):
    d = tmp_path / "docs"
    d.mkdir()
    (d / "thesis.txt").write_text("precious")
    rc, out, err = run_cli(capsys, d, "--video", inputs["video"], "--keypoints", inputs["kp"], "--masks", inputs["masks"])
    assert rc != 0 and "not a MoRF project" in err
    assert (d / "thesis.txt").read_text() == "precious"


def test_truncated_video_keeps_decodable_frames(tmp_path, inputs, capsys):
    data = write_video(tmp_path / "full.avi", 20).read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    masks = write_masks(tmp_path / "m", 20)
    kp = write_openpose(tmp_path / "k", 20, [(10, 8, 30, 40)])
    root = tmp_path / "pc"
    rc, out, err = run_cli(capsys, root, "--video", cut, "--keypoints", kp, "--masks", masks)
    assert rc == 0, err
    assert "warning" in err and "could be decoded" in err
    p = CaptureProject.open(root)
    assert 0 < p.num_frames < 20
    assert p.manifest["ingest"]["warnings"]


def test_images_with_a_frame_rate_are_a_clip(tmp_path, capsys):
    frames = write_frames(tmp_path / "frames", 4)
    kp = write_openpose(tmp_path / "kp", 4, [(20, 5, 60, 45)], pattern="img_{i}_keypoints.json")
    masks = write_masks(tmp_path / "masks", 4, pattern="img_{i}_mask.png")
    rc, out, err = run_cli(capsys, tmp_path / "p", "--frames", frames, "--keypoints", kp, "--masks", masks,
                           "--fps", "24")
    assert rc == 0, err
    p = CaptureProject.open(tmp_path / "p")
    assert not p.unordered_views and p.frame_times() == pytest.approx(np.arange(4) / 24.0)
    assert "unordered" not in out


def test_openpose_hands_face_and_largest_person(tmp_path, capsys):
    frames = write_frames(tmp_path / "frames", 4)
    # two people in every file; the second is larger and must be the one followed
    kp = write_openpose(tmp_path / "kp", 4, [(2, 2, 12, 20), (20, 5, 60, 45)], hands=True, pattern="img_{i}_keypoints.json")
    masks = write_masks(tmp_path / "masks", 4, pattern="img_{i}_mask.png")
    root = tmp_path / "p"
    rc, out, err = run_cli(capsys, root, "--frames", frames, "--keypoints", kp, "--masks", masks)
    assert rc == 0, err
    assert "2 people seen; following the largest" in out
    p = CaptureProject.open(root)
    pts = p.load_keypoints().points
    seen = pts[..., 2] > 0
    assert (pts[..., 0][seen] >= 20).all(), "followed the smaller person"
    assert p.manifest["ingest"]["people"]["seen"] == 2
    # images without --fps are a photo set: unordered views, no frame rate, no times
    assert p.unordered_views and p.fps is None and p.frame_times() is None
    assert "recorded as unordered views" in out
    from morf.io import load_npz

    hf = load_npz(root / p.manifest["ingest"]["hands_face"])
    assert hf["hand_left"].shape == (4, 21, 3) and hf["face"].shape == (4, 70, 3)
    assert hf["present"].all()
    assert hf["hand_right"][0, 0].tolist() == pytest.approx([3.5, 4.5, 0.6])


def test_stop_midway_leaves_the_previous_project(project, inputs):
    from morf.capture.ingest import IngestConfig, ingest
    from morf.pipeline.control import StageControl, StopRequested

    before = snapshot(project)
    seen = []

    def on_progress(p):
        seen.append(p.step)
        if p.step == 2:
            control.stop()

    control = StageControl(on_progress)
    config = IngestConfig(video=inputs["video"], keypoints=inputs["kp"], masks=inputs["masks"], max_frames=3)
    with pytest.raises(StopRequested):
        ingest(project, config, control, log=lambda s: None)
    assert seen == [1, 2]
    assert snapshot(project) == before
    assert not list(project.parent.glob(".proj.ingest-*"))


def _one_line_error(rc: int, err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("morf ingest: error: "), (rc, err)
    return lines[0]


def test_no_person_in_any_frame_is_an_error_that_leaves_nothing(project, tmp_path, inputs, capsys):
    nobody = write_openpose(tmp_path / "nobody", 6, [])  # OpenPose found nobody in any frame
    args = ["--video", inputs["video"], "--keypoints", nobody, "--masks", inputs["masks"]]

    rc, out, err = run_cli(capsys, tmp_path / "new" / "deeper" / "proj", *args)
    assert "no person was found in any of the 6 frames" in _one_line_error(rc, err)
    assert not (tmp_path / "new").exists(), "folders made for the project were left behind"

    had = tmp_path / "had"  # a folder the user made for it stays exactly as it was
    had.mkdir()
    had.chmod(0o750)
    before = had.stat()
    rc, out, err = run_cli(capsys, had, *args)
    _one_line_error(rc, err)
    after = had.stat()
    assert list(had.iterdir()) == [] and (after.st_ino, after.st_mode) == (before.st_ino, before.st_mode)

    before = snapshot(project)  # an existing project, even with --force, is kept
    rc, out, err = run_cli(capsys, project, *args, "--force")
    _one_line_error(rc, err)
    assert snapshot(project) == before
    assert not [p.name for p in tmp_path.iterdir() if ".ingest-" in p.name], "staging folder left behind"


def test_a_video_without_a_person_fails_through_the_command(tmp_path, inputs):
    """MediaPipe on frames that show no person, run as a user runs it."""
    import subprocess
    import sys

    require("mediapipe")
    video = write_video(tmp_path / "empty room.avi", 3)
    r = subprocess.run([sys.executable, "-m", "morf.cli.main", "ingest", str(tmp_path / "proj"), "--video", str(video)],
                       capture_output=True, text=True, timeout=300)
    line = _one_line_error(r.returncode, r.stderr)
    assert "no person was found in any of the 3 frames" in line and "film one person" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty room.avi", "in"]


def test_face_and_hand_landmarks_are_detected_unless_openpose_brought_them(tmp_path, capsys):
    from morf.capture.landmarks_face_hands import LANDMARKS_FILE, load_landmarks

    frames = write_frames(tmp_path / "frames", 3)
    masks = write_masks(tmp_path / "masks", 3, pattern="img_{i}_mask.png")
    body_only = write_openpose(tmp_path / "kp", 3, [(20, 5, 60, 45)], pattern="img_{i}_keypoints.json")
    with_hands = write_openpose(tmp_path / "kph", 3, [(20, 5, 60, 45)], hands=True, pattern="img_{i}_keypoints.json")
    # OpenPose's own face and hand points are the evidence: no detector runs
    rc, out, err = run_cli(capsys, tmp_path / "a", "--frames", frames, "--keypoints", with_hands, "--masks", masks)
    assert rc == 0, err
    a = CaptureProject.open(tmp_path / "a")
    assert not (a.root / LANDMARKS_FILE).exists() and load_landmarks(a).source == "openpose"
    # asked not to: nothing
    rc, out, err = run_cli(capsys, tmp_path / "b", "--frames", frames, "--keypoints", body_only, "--masks", masks,
                           "--no-face-hands")
    assert rc == 0, err
    assert load_landmarks(CaptureProject.open(tmp_path / "b")) is None
    # body keypoints alone: the landmarks are detected and stored for every frame
    require("mediapipe")
    rc, out, err = run_cli(capsys, tmp_path / "c", "--frames", frames, "--keypoints", body_only, "--masks", masks)
    assert rc == 0, err
    c = CaptureProject.open(tmp_path / "c")
    lm = load_landmarks(c)
    assert (c.root / LANDMARKS_FILE).is_file() and lm.source == "mediapipe" and lm.num_frames == 3
    assert "face landmarks found in" in out
