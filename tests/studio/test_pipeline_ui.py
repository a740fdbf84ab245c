"""The real pipeline driven from the studio's UI, headless, on a tiny synthetic capture.

Fit -> train (tiny preset) -> export -> live render of a retargeted motion, all started by
scripted clicks; then closing the app in the middle of training keeps a checkpoint that
``morf train`` resumes.
"""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

from tests.conftest import require

pytestmark = [pytest.mark.gl, pytest.mark.slow]

imgui = require("imgui_bundle").imgui
from studio.app import StudioApp  # noqa: E402

K = imgui.Key
TRAIN_OPTIONS = {"steps": 20, "inpaint_steps": 2}  # on top of the tiny preset chosen in the UI
RESUME_STEPS = 40  # the interrupted run's length: closed after ~10 steps, resumed to the end


@pytest.fixture(scope="module")
def synthetic_capture(tmp_path_factory, body_model):
    """``morf synth P --preset tiny``, made once; each test works on its own copy."""
    from morf.synth import make_synthetic_capture, synth_config

    root = tmp_path_factory.mktemp("synth") / "tiny"
    make_synthetic_capture(root, synth_config("tiny"), model=body_model)
    return root


@pytest.fixture
def project_copy(synthetic_capture, tmp_path):
    dst = tmp_path / "capture"
    shutil.copytree(synthetic_capture, dst)
    return dst


def run_until(app: StudioApp, done, timeout: float, on_frame=None) -> None:
    """Run UI frames until ``done()``; fail after ``timeout`` seconds with the worker's state."""
    end = time.monotonic() + timeout
    while not done():
        if time.monotonic() > end:
            snap = app.worker.latest()
            raise AssertionError(f"timed out: stage {snap.stage} {snap.state}, error {snap.error}, {snap.message}")
        app.frame()
        if on_frame is not None:
            on_frame()
        time.sleep(0.01)


def wait_stage(app: StudioApp, stage: str, timeout: float) -> list:
    """Frames until ``stage`` ends; returns the distinct snapshots the UI drew while it ran."""
    seen = {}

    def record():
        s = app.worker.latest()
        if s.stage == stage and s.progress is not None:
            seen[s.seq] = s

    run_until(app, lambda: app.worker.latest().stage == stage, 10.0)
    run_until(app, lambda: not app.worker.latest().busy, timeout, record)
    app.frame()  # the UI notices the stage ended (refreshes the project, opens a new avatar)
    snap = app.worker.latest()
    assert snap.state == "finished", f"{stage} {snap.state}: {snap.error}"
    return [seen[k] for k in sorted(seen)]


def motion_file(shared_data_dir, tmp_path):
    """A CMU BVH from the shared data when present, else a small clip the test writes."""
    if shared_data_dir is not None:
        bvh = sorted((shared_data_dir / "motion" / "cmu").glob("*.bvh"))
        if bvh:
            return bvh[0]
    from morf.io import save_npz

    t = np.linspace(0, 1, 30, dtype=np.float32)
    rot = np.zeros((30, 104, 3), np.float32)
    rot[:, 0, 2] = 2 * np.pi * t  # a full turn about the vertical axis
    out = tmp_path / "motions" / "turn.npz"
    out.parent.mkdir(parents=True, exist_ok=True)
    save_npz(out, rotvecs=rot, transl=np.zeros((30, 3), np.float32), fps=np.float32(30.0))
    return out


@pytest.fixture
def shared_motion_dir(request):
    """The shared data folder when it is present (``shared_data`` skips without it; here the test
    falls back on a motion it writes itself)."""
    try:
        d = request.getfixturevalue("shared_data")
    except pytest.skip.Exception:
        return None
    return d if (d / "motion" / "cmu").is_dir() else None


def test_fit_train_export_and_live_render_from_the_ui(make_app, project_copy, tmp_path, shared_motion_dir):
    from morf.capture.project import CaptureProject

    project = CaptureProject.open(project_copy)
    motion = motion_file(shared_motion_dir, tmp_path)
    app = make_app(project_copy, stages=None, unavailable=None, motion_dir=str(motion.parent))  # the library's stages
    app.state.stage_presets["fit"] = "tiny"  # even the "fast" preset takes ~35 s on 2 cores for 12 frames
    app.state.stage_options["train"] = TRAIN_OPTIONS
    app.settle()
    app.press(K._4)

    # Fit, started by its button; the training panel shows its live snapshots.
    app.click_item("stage:fit")
    fit_snaps = wait_stage(app, "fit", 60)
    assert len(fit_snaps) >= 3 and any(s.curves for s in fit_snaps)
    assert project.fits_path.is_file()
    assert app.view.has_fit_overlays()  # the frames panel now shows the real fit

    # Train with the tiny preset, chosen in the preset picker; watch the warp panel meanwhile.
    app.click_item("preset:train")
    app.click_item("preset:train:tiny")
    assert app.state.stage_presets["train"] == "tiny"
    app.click_item("stage:train")
    app.press(K._3)
    train_snaps = wait_stage(app, "train", 90)
    curve_lengths = [len(next(iter(s.curves.values())).steps) for s in train_snaps if s.curves]
    assert len(set(curve_lengths)) >= 2, "the loss curves did not grow while training ran"
    warp_steps = {s.progress.step for s in train_snaps if any(n.startswith("warp") for n in s.progress.images)}
    assert len(warp_steps) >= 2, "warp-field images did not update"
    assert "warp:warp" in app.textures._previews  # the warp panel drew them
    run_dir = project.runs_dir / "morf-tiny"
    assert (run_dir / "avatar.pt").is_file()

    # Export from the UI; the live render opens the new int8 avatar.
    app.press(K._4)
    app.click_item("stage:export")
    wait_stage(app, "export", 90)
    assert (project.avatar_dir / "renderer_int8.onnx").is_file()
    assert app.live is not None and app.live.wait_open(30) and app.live.ready, app.live.note

    # Live render: pick the motion, play it; frames arrive from the render thread with an fps.
    app.press(K._5)
    app.frame()
    app.click_item(f"motion:{motion.name}")
    run_until(app, lambda: app.live_panel.clip is not None or app.live_panel.clip_note, 60)
    assert app.live_panel.clip is not None, app.live_panel.clip_note
    app.press(K.space)
    assert app.state.playing
    keys = set()
    run_until(app, lambda: len(keys) >= 4 and app.live.latest().fps is not None, 60,
              lambda: keys.add(app.live.latest().key if app.live.latest() else None))
    frame = app.live.latest()
    assert len({k[1] for k in keys if k}) >= 3, "the motion did not advance"
    # 20 training steps teach the renderer little (its mask is still grey everywhere), but the
    # posed body must show: the image is not flat.
    assert frame.image.std() > 2.0, "the live render is a flat image"
    assert app.live_stats and all(ms > 0 for _, ms in app.live_stats)


def test_closing_while_training_keeps_a_checkpoint_that_morf_train_resumes(make_app, project_copy, capsys):
    import torch

    from morf.cli.main import main

    app = make_app(project_copy, stages=None, unavailable=None)
    app.state.stage_presets["train"] = "tiny"
    app.state.stage_options["train"] = {"steps": RESUME_STEPS}
    app.settle()
    app.press(K._4)
    app.click_item("stage:train")

    def training_steps() -> int:
        s = app.worker.latest()
        return s.progress.step if s.stage == "train" and s.progress is not None and s.curves else 0

    run_until(app, lambda: training_steps() >= 10, 90)
    app.close()  # what the window's close button does
    assert not app.worker.alive
    assert app.worker.latest().state == "stopped"
    run_dir = project_copy / "runs" / "morf-tiny"
    stopped_at = int(torch.load(run_dir / "checkpoint.pt", map_location="cpu", weights_only=True)["step"])
    assert 10 <= stopped_at < RESUME_STEPS
    assert not (run_dir / "avatar.pt").is_file()
    capsys.readouterr()
    assert main(["train", str(project_copy), "--preset", "tiny", "--steps", str(RESUME_STEPS)]) == 0
    out = capsys.readouterr().out
    assert f"resumed at step {stopped_at}" in out, out
    assert (run_dir / "avatar.pt").is_file()
