"""The studio as the front door: a project made from a video (start screen, drop, command line),
opened in the Frames panel as soon as its frames exist while the body is fitted, stopped and
continued as 'morf run' continues it."""

from __future__ import annotations

import shlex
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from morf.cli.main import build_parser
from morf.io import write_image
from morf.pipeline.control import Progress
from screenshots import check_golden
from studio import pipeline_run
from studio.commands import Stop
from tests.conftest import require

imgui = require("imgui_bundle").imgui
K = imgui.Key
WAIT_S = 90.0  # ingest with MediaPipe on 6 frames takes a few seconds; a loaded CI machine more


@pytest.fixture(scope="module")
def tiny_clip(tmp_path_factory, body_model) -> Path:
    """6 frames of a rendered person turning (the first of morf synth's tiny capture) as an .mp4."""
    import cv2

    from morf.synth import make_synthetic_capture, synth_config

    root = tmp_path_factory.mktemp("clip")
    project = make_synthetic_capture(root / "synth", synth_config("tiny"), model=body_model)
    frames = [project.load_frame(i) for i in range(6)]
    h, w = frames[0].shape[:2]
    out = root / "clip.mp4"
    writer = cv2.VideoWriter(str(out), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (w, h))
    for f in frames:
        writer.write(np.ascontiguousarray(f[..., ::-1]))
    writer.release()
    assert out.stat().st_size > 0
    return out


def _until(app, done, what: str, timeout: float = WAIT_S) -> None:
    end = time.monotonic() + timeout
    while not done():
        if time.monotonic() > end:
            snap = app.worker.latest()
            pytest.fail(f"{what}: not within {timeout:.0f} s (worker: {snap.stage} {snap.state}, {snap.error})")
        app.frame()
        time.sleep(0.05)  # the worker needs the CPU more than the test needs frames


@pytest.fixture
def endless_fit(monkeypatch):
    """The fit stands in for the real one: reports a step, then waits to be stopped (an event
    says it started)."""
    started = threading.Event()

    def fit(args, control):
        control.report(Progress("fit", step=3, total=10, message="fitting body pose, stage 1 of 3"))
        started.set()
        while True:
            control.check()
            time.sleep(0.01)

    monkeypatch.setitem(pipeline_run.RUNNERS, "fit", fit)
    return started


@pytest.mark.gl
def test_a_video_opens_in_the_frames_panel_while_the_body_is_fitted_and_continues_after_a_stop(
        make_app, tiny_clip, tmp_path, endless_fit, capsys):
    require("mediapipe")
    (tmp_path / "clip.mp4").symlink_to(tiny_clip)
    app = make_app(None)
    app.settle()
    app.click_item("new_source")
    app.type_text("clip.mp4")  # typed, as a user would (relative to the working folder)
    app.click_item("new_folder")
    app.type_text("capture")
    app.click_item("make_avatar")
    _until(app, lambda: endless_fit.is_set() and app.view is not None, "the frames in the Frames panel")
    app.settle()
    snap = app.worker.latest()
    assert app.state.panel == 0 and app.view.name == "capture" and app.view.num_frames == 6
    assert snap.stage == "fit" and snap.chain_step == (2, 4) and snap.state == "running"
    check_golden("studio_new_project", app.frame(capture=True))
    # stopped, then continued from the Training panel: ingest is skipped, the fit starts again
    app.send(Stop())
    _until(app, lambda: not app.worker.latest().busy, "the stop")
    snap = app.worker.latest()
    assert snap.state == "stopped" and "morf run capture --video clip.mp4" in snap.message
    again = shlex.split(snap.message.split("as does: ")[1])  # the command it suggests parses as morf's own
    assert again[:2] == ["morf", "run"] and build_parser().parse_args(again[1:]).video == Path("clip.mp4")
    endless_fit.clear()
    app.press(K._4)
    app.click_item("make_avatar")
    _until(app, endless_fit.is_set, "the fit again")
    assert "[1/4] ingest: skipped" in capsys.readouterr().out
    assert app.worker.latest().chain_step == (2, 4)


@pytest.mark.gl
def test_a_bad_start_fails_in_one_line_on_the_start_screen(make_app, tmp_path):
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "notes.txt").write_text("mine")
    (tmp_path / "clip.mp4").write_bytes(b"")
    app = make_app(None)
    app.settle()
    app.start_pipeline(pipeline_run.PipelineRequest("taken", "clip.mp4"))
    _until(app, lambda: app.worker.latest().state == "failed", "the refusal")
    assert "taken exists and is not a MoRF capture project; choose a new folder" in app.worker.latest().error
    assert (tmp_path / "taken" / "notes.txt").read_text() == "mine"
    app.start_pipeline(pipeline_run.PipelineRequest("new", "missing.mp4"))
    _until(app, lambda: "missing.mp4" in (app.worker.latest().error or ""), "the missing video")
    assert not (tmp_path / "new").exists()


@pytest.mark.gl
def test_drops_fill_the_new_project_open_a_project_and_play_a_motion(make_app, tiny_project, tmp_path):
    (tmp_path / "clip.mp4").write_bytes(b"")  # a drop is told by its name; the pipeline reads it
    shots = tmp_path / "shots"
    shots.mkdir()
    for i in range(3):
        write_image(shots / f"{i:03d}.png", np.full((8, 8, 3), 60 * i, np.uint8))
    app = make_app(None)
    app.settle()
    app.drop(["clip.mp4"])
    app.settle()
    assert (app.state.new_source, app.state.new_folder) == ("clip.mp4", "clip_project")
    check_golden("studio_drop_video", app.frame(capture=True))
    app.drop(["shots"])  # a folder of images: looked into off the UI thread
    _until(app, lambda: app.state.new_source == "shots", "the frames folder", 10.0)
    assert app.state.new_folder == "shots_project"
    app.drop(["capture"])
    _until(app, lambda: app.view is not None, "the dropped project", 10.0)
    assert app.view.name == "capture"
    app.drop(["clip.mp4"])  # a video over an open project (nothing running): back to the start screen
    app.frame()
    assert app.view is None and app.state.new_source == "clip.mp4"


def test_the_command_line_takes_a_video_for_a_new_folder_only(capsys):
    from studio.app import main

    assert main(["--video", "clip.mp4", "--headless-frames", "1"]) == 2
    assert "give its folder first, 'morf-studio NEWFOLDER --video FILE'" in capsys.readouterr().err
    assert main(["new", "--video", "clip.mp4", "--stage", "fit", "--headless-frames", "1"]) == 2
    assert "give one" in capsys.readouterr().err
    assert main(["new", "--video", "clip.mp4", "--preset", "huge", "--headless-frames", "1"]) == 2
    assert "--preset is the training size: one of tiny" in capsys.readouterr().err
