"""``morf run``: video -> avatar in one command; finished stages skipped, stopped ones resumed,
bad starts refused in one line."""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from morf.capture.project import CaptureProject
from morf.cli.main import main

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "capture"))
from capture_helpers import write_masks, write_openpose, write_video  # noqa: E402


def run(capsys, *argv) -> tuple[int, str, str]:
    rc = main(["run", *map(str, argv)])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_run_until_fit_then_continue_to_export(tiny_capture, capsys, one_torch_thread):
    project = tiny_capture.root
    rc, out, err = run(capsys, project, "--preset", "tiny", "--until", "fit")
    assert rc == 0, err
    assert "[1/2] ingest: skipped (already done: 12 frames of a synthetic capture" in out
    assert "[2/2] fit: morf fit" in out and "[2/2] fit: done in" in out
    assert (project / "fits" / "fits.npz").is_file() and not (project / "runs").exists()
    assert json.loads((project / "run.json").read_text()) == {"preset": "tiny", "holdout": None}

    # the same project again, no options: the tiny size is remembered, done stages are skipped
    rc, out, err = run(capsys, project)
    assert rc == 0, err
    assert "[1/4] ingest: skipped" in out and "[2/4] fit: skipped (already done" in out
    assert "[3/4] train: morf train" in out and "--preset tiny" in out and "[3/4] train: done in" in out
    assert "[4/4] export: done in" in out and "avatar ready in" in out
    manifest = json.loads((project / "avatar" / "manifest.json").read_text())
    assert manifest["source"]["run"] == "morf-tiny"

    rc, out, err = run(capsys, project)
    assert rc == 0, err
    assert [line.split(":")[0] for line in out.splitlines() if "skipped (already done" in line] == \
        ["[1/4] ingest", "[2/4] fit", "[3/4] train", "[4/4] export"]


def test_run_ingests_a_video_once(tmp_path, capsys):
    video = write_video(tmp_path / "clip.avi", 6)
    kp, masks = write_openpose(tmp_path / "kp", 6, [(10, 8, 30, 40)]), write_masks(tmp_path / "masks", 6)
    root = tmp_path / "proj"
    rc, out, err = run(capsys, root, "--video", video, "--keypoints", kp, "--masks", masks, "--until", "ingest")
    assert rc == 0, err
    assert "[1/1] ingest: morf ingest" in out and "[1/1] ingest: done in" in out
    assert CaptureProject.open(root).num_frames == 6
    rc, out, err = run(capsys, root, "--video", video, "--until", "ingest")
    assert rc == 0, err
    assert "[1/1] ingest: skipped (already done: 6 frames from clip.avi)" in out


def one_line_error(capsys, *argv) -> str:
    rc, out, err = run(capsys, *argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("morf run: error: "), (rc, out, err)
    return lines[0]


def test_bad_starts_are_one_line_errors(tmp_path, capsys):
    other = write_video(tmp_path / "other.avi", 4)
    images = CaptureProject.create(tmp_path / "imgs", num_frames=2, width=64, height=48, fps=None,
                                   source={"kind": "images", "path": str(tmp_path)}).root
    filmed = CaptureProject.create(tmp_path / "filmed", num_frames=2, width=64, height=48, fps=10.0,
                                   source={"kind": "video", "path": str(tmp_path / "clip.mp4")}).root
    papers = tmp_path / "papers"
    papers.mkdir()
    (papers / "thesis.txt").write_text("precious")
    assert "video not found" in one_line_error(capsys, tmp_path / "new", "--video", tmp_path / "missing.mp4")
    assert "give --video FILE" in one_line_error(capsys, tmp_path / "new")
    assert "not a MoRF capture project" in one_line_error(capsys, papers, "--video", other)
    assert "capture made from images, not one made from a video" in one_line_error(capsys, images, "--video", other)
    assert "was made from" in one_line_error(capsys, filmed, "--video", other)
    assert "--holdout must be at least 2" in one_line_error(capsys, filmed, "--holdout", "1")
    assert "--masks, --every go with --video" in one_line_error(capsys, filmed, "--masks", tmp_path, "--every", "2")
    assert (papers / "thesis.txt").read_text() == "precious" and not (tmp_path / "new").exists()


def test_stopped_fits_and_runs_are_resumed_with_their_own_settings(tmp_path):
    from morf.cli.project_steps import fit_options, train_plan
    from morf.errors import InputError
    from morf.presets import preset
    from morf.train.run_dir import RunDir

    assert fit_options(preset("fit", "fast")) == ("--preset", "fast")
    assert fit_options(preset("fit", "default").replace(temporal=False, overlays=False)) == \
        ("--preset", "default", "--no-temporal", "--no-overlays")
    assert fit_options(preset("fit", "default").replace(keypoint_weight=123.0)) is None

    root = CaptureProject.create(tmp_path / "p", num_frames=2, width=64, height=48, fps=10.0,
                                 source={"kind": "video"}).root
    fresh = ("train", str(root), "--preset", "tiny", "--name", "morf-tiny")
    assert train_plan(root, "morf-tiny", fresh).action == "run"
    cfg = preset("train", "tiny").replace(holdout=4)
    RunDir(root / "runs" / "morf-tiny").save_config(cfg)
    plan = train_plan(root, "morf-tiny", fresh)
    assert plan.action == "resume" and plan.argv[2:4] == ("--config", str(root / "runs" / "morf-tiny" / "config.json"))
    with pytest.raises(InputError, match="--holdout 4"):
        train_plan(root, "morf-tiny", fresh, holdout=8)


def _hint(out: str) -> str:
    """The command line of the retry hint printed after a failed stage."""
    line = next(line for line in out.splitlines() if "fix it and continue with: " in line)
    return line.split("fix it and continue with: ", 1)[1]


def test_retry_hint_keeps_every_option_and_works_pasted(tmp_path, capsys):
    base = tmp_path / "my captures"
    base.mkdir()
    video = write_video(base / "my clip.avi", 6)
    kp = write_openpose(base / "kp files", 5, [(10, 8, 30, 40)])  # one file short: ingest fails
    masks = write_masks(base / "the masks", 6)
    root = base / "my proj"
    rc, out, err = run(capsys, root, "--video", video, "--keypoints", kp, "--masks", masks, "--every", "1",
                       "--until", "ingest", "--preset", "tiny", "--holdout", "3")
    assert rc == 2 and "no OpenPose file for frame 5" in err and not root.exists()
    hint = _hint(out)
    argv = shlex.split(hint)
    assert argv[:3] == ["morf", "run", str(root)]
    given = dict(zip(argv[3::2], argv[4::2]))
    assert given == {"--video": str(video), "--keypoints": str(kp), "--masks": str(masks), "--every": "1",
                     "--until": "ingest", "--preset": "tiny", "--holdout": "3"}, hint

    write_openpose(kp, 6, [(10, 8, 30, 40)])  # the fix; then the hint, pasted into a shell
    morf = Path(sys.executable).with_name("morf")
    if not morf.is_file():
        pytest.skip(f"no morf command beside {sys.executable}")
    env = {**os.environ, "PATH": f"{morf.parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    r = subprocess.run(hint, shell=True, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert CaptureProject.open(root).num_frames == 6
    assert json.loads((root / "run.json").read_text()) == {"preset": "tiny", "holdout": 3}
    assert "continue to the export with: morf run " + shlex.quote(str(root)) in r.stdout


def test_info_lists_runs_without_the_projects_own_folders(tmp_path, capsys):
    root = CaptureProject.create(tmp_path / "p", num_frames=2, width=64, height=48, fps=10.0,
                                 source={"kind": "video"}).root
    for name in (".cache", ".old-run", "morf-cpu", "morf-tiny"):
        (root / "runs" / name).mkdir(parents=True)
    (root / "runs" / "notes.txt").write_text("mine")
    assert main(["info", str(root), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["runs"] == ["morf-cpu", "morf-tiny"]
