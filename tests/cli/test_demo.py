"""The whole pipeline through the command line, as the README's first command runs it (tiny size)."""

import json

import cv2
import pytest

from morf.cli.main import main


@pytest.mark.slow
def test_demo_tiny_runs_every_stage_and_resumes(tmp_path, capsys):
    root = tmp_path / "demo"
    assert main(["demo", str(root), "--preset", "tiny"]) == 0
    capture = root / "capture"
    assert (capture / "fits" / "fits.npz").is_file()
    assert (capture / "runs" / "demo-tiny" / "avatar.pt").is_file()
    manifest = json.loads((capture / "avatar" / "manifest.json").read_text())
    assert manifest["format"] == "morf-avatar"
    video = cv2.VideoCapture(str(root / "animation.mp4"))
    assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == 8
    ok, frame = video.read()
    assert ok and frame.std() > 1.0  # something was drawn
    # a second run skips every finished stage and renders the animation again
    capsys.readouterr()
    assert main(["demo", str(root), "--preset", "tiny"]) == 0
    out = capsys.readouterr().out
    for stage in ("synthetic capture", "body fits", "avatar training", "int8 export"):
        assert f"{stage}: skipped (already done" in out, stage
    assert "[5/5] animation: done" in out


def test_info_reports_excluded_frames(tiny_capture, capsys):
    p = tiny_capture
    p.set_user_decision(2, "drop")
    assert main(["info", str(p.root), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["frames"] == 12 and info["synthetic"] is True
    assert {"frame": 2, "reason": "dropped by user"} in info["excluded"]


def test_animate_without_avatar_is_one_line_error(tiny_capture, tmp_path, capsys):
    p = tiny_capture
    rc = main(["animate", str(p.root), "--motion", "x.bvh", "--out", str(tmp_path / "v.mp4")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "no exported avatar" in err[0]


def test_not_a_project_is_one_line_error(tmp_path, capsys):
    rc = main(["info", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "not a MoRF capture project" in err[0]


def test_train_preset_auto_logs_its_choice(tiny_capture, capsys):
    p = tiny_capture
    # no inpainting: its fixed 200 fine-tuning steps were 80% of this test, and the choice is logged
    # before it; one step of one image: the choice is made before training (the steps' backward
    # passes on the chosen renderer were most of what was left)
    rc = main(["train", str(p.root), "--preset", "auto", "--steps", "1", "--resolution", "64", "--fits", "ground-truth",
               "--set", "inpaint_steps=0", "--set", "batch_size=1"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "automatic size choice" in out and "texture" in out
    config = json.loads((p.runs_dir / "morf-auto" / "config.json").read_text())
    assert config["preset"] == "auto"
    assert (p.runs_dir / "morf-auto" / "auto_size.txt").read_text().strip()
