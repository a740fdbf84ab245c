"""Screenshot-diff tests of the studio, headless (GLFW null platform + EGL), with scripted input."""

from __future__ import annotations

import time

import numpy as np
import pytest

from screenshots import WINDOW, check_golden
from tests.conftest import require
from morf.errors import MorfError
from morf.pipeline.control import Progress

pytestmark = pytest.mark.gl

imgui = require("imgui_bundle").imgui
from studio.app import StudioApp  # noqa: E402  (after the skip)
from studio.commands import StartStage  # noqa: E402
from studio.snapshot import LossCurve, Snapshot  # noqa: E402

K = imgui.Key


def shot(app: StudioApp) -> np.ndarray:
    app.settle()
    img = app.frame(capture=True)
    assert img.shape == (WINDOW[1], WINDOW[0], 3)
    return img


def test_frames_panel_shows_frame_overlays_and_strip(make_app, tiny_project):
    app = make_app("capture")
    assert app.view is not None and app.state.project_error is None
    img = shot(app)
    check_golden("studio_frames", img)
    # the frame view is not empty: frame 0's backdrop (R=40, B=90) and the mask tint are on screen
    assert (np.abs(img[..., 2].astype(int) - 90) < 6).sum() > 1000


def test_review_keys_drop_restore_and_the_filtered_panel(make_app, tiny_project):
    app = make_app("capture")
    app.settle()
    app.press(K.right_arrow)
    app.press(K.j)
    assert app.state.frame == 2
    app.press(K.d)
    app.settle()
    assert tiny_project.load_review()["drop"] == [2]
    assert app.view.decisions[2].reason == "dropped by user"
    app.press(K._2)
    assert app.state.panel == 1
    check_golden("studio_filtered", shot(app))
    app.press(K.r)
    app.settle()
    assert tiny_project.load_review() == {"drop": [], "keep": []}
    assert app.view.decisions[2].used
    # N walks the flagged frames: 1 (automatic filter), 4 (no person), then around again
    app.press(K.n)
    assert app.state.frame == 4
    app.press(K.n)
    assert app.state.frame == 1
    app.press(K.r)  # restoring a filtered frame keeps it against the filter
    app.settle()
    assert tiny_project.load_review()["keep"] == [1]
    app.press(K.left_arrow)
    app.press(K.k)
    assert app.state.frame == 5  # wraps around


def test_overlay_toggles_playback_and_panel_keys(make_app, tiny_project):
    app = make_app("capture")
    app.settle()
    for key, attr in ((K.o, "show_keypoints"), (K.m, "show_mask"), (K.f, "show_fit")):
        before = getattr(app.state, attr)
        app.press(key)
        assert getattr(app.state, attr) is (not before)
    app.press(K.space)  # play at the capture's 10 fps with a fixed 1/60 s frame time
    assert app.state.playing
    start = app.state.frame
    for _ in range(12):
        app.frame()
    assert app.state.frame == (start + 2) % 6
    app.press(K.space)
    assert not app.state.playing
    app.press(K.tab)
    assert app.state.panel == 1
    app.press(K._4)
    assert app.state.panel == 3
    app.press(K._1)
    assert app.state.panel == 0


def test_clicking_a_thumbnail_selects_its_frame(make_app, tiny_project):
    app = make_app("capture")
    app.settle()
    app.click(220, 690)  # the fourth thumbnail of the strip (frame 3; 54 px wide, 6 px apart)
    assert app.state.frame == 3


def test_help_overlay_lists_the_keys(make_app, tiny_project):
    app = make_app("capture")
    app.settle()
    app.press(K.h)
    assert app.state.show_help
    check_golden("studio_help", shot(app))
    app.press(K.escape)
    assert not app.state.show_help
    app.press(K.f1)
    assert app.state.show_help


def test_damaged_project_shows_a_message_not_a_crash(make_app, tmp_path):
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "morf_project.json").write_text("{ not json")
    app = make_app("broken")
    assert app.view is None
    assert "damaged project manifest" in app.state.project_error
    check_golden("studio_bad_project", shot(app))
    app.open_project("empty_folder_that_is_missing")
    assert "not found" in app.state.project_error
    (tmp_path / "plain").mkdir()
    app.open_project("plain")
    assert "is not a MoRF capture project" in app.state.project_error


def test_start_screen_opens_a_typed_path(make_app, tiny_project):
    app = make_app(None)
    app.settle()
    assert app.view is None
    app.click_item("open_path")
    assert imgui.get_io().want_text_input
    app.press(K.d)  # typing, not a review key: nothing is dropped
    app.type_text("capture")
    app.press(K.enter)
    app.settle()
    assert app.view is not None and app.view.name == "capture", app.state.project_error
    assert tiny_project.load_review()["drop"] == []


def test_training_panel_with_losses_and_controls(make_app, tiny_project):
    app = make_app("capture")
    app.settle()
    steps = np.arange(1, 201, dtype=np.float64)
    curves = {"l1": LossCurve(steps, 0.3 * np.exp(-steps / 60) + 0.02),
              "perceptual": LossCurve(steps, 0.8 * np.exp(-steps / 90) + 0.1)}
    preview = np.zeros((64, 64, 3), np.uint8)
    preview[..., 0] = np.linspace(0, 255, 64, dtype=np.uint8)[None, :]
    progress = Progress("train", step=200, total=1000, message="stage 1 of 2", losses={"l1": 0.05, "perceptual": 0.2},
                        images={"render": preview})
    app.worker.mailbox.publish(Snapshot(seq=1000, state="paused", stage="train", progress=progress, curves=curves,
                                        elapsed_s=100.0, seconds_per_step=0.5, eta_s=400.0, project="capture"))
    app.press(K._4)
    check_golden("studio_training", shot(app))


def test_warp_panel_empty_and_with_a_training_snapshot(make_app, tiny_project):
    app = make_app("capture")
    app.settle()
    app.press(K._3)
    check_golden("studio_warp_empty", shot(app))
    yy, xx = np.mgrid[0:96, 0:96]
    warp = np.stack([xx * 255 // 95, yy * 255 // 95, np.full_like(xx, 128)], -1).astype(np.uint8)
    effect = np.zeros((96, 96, 3), np.uint8)
    effect[::8] = 200
    app.worker.mailbox.publish(Snapshot(seq=2000, state="running", stage="train", project="capture",
                                        progress=Progress("train", step=40, total=100, frame=3,
                                                          images={"warp": warp, "warp_effect": effect})))
    check_golden("studio_warp", shot(app))


class GradientPlayer:
    """A fake player: a colour gradient that depends on the camera's yaw."""

    def __init__(self):
        self.calls = []

    def render(self, pose, camera):
        self.calls.append(camera)
        h, w = camera.height, camera.width
        img = np.zeros((h, w, 3), np.uint8)
        img[..., 0] = np.linspace(0, 255, w, dtype=np.uint8)[None, :]
        img[..., 1] = np.linspace(0, 255, h, dtype=np.uint8)[:, None]
        img[..., 2] = 128
        return img


def test_live_panel_without_and_with_a_player(make_app, tiny_project, tmp_path):
    (tmp_path / "motions" / "walk.bvh").write_text("HIERARCHY\n")
    (tmp_path / "motions" / "turn.npz").write_bytes(b"")
    app = make_app("capture")
    app.settle()
    app.press(K._5)
    check_golden("studio_live_empty", shot(app))
    player = GradientPlayer()
    app.show_player(player)
    app.settle()
    assert app.live.alive and app.live.latest() is not None
    # the render's fps / ms text depends on timing: blank it out
    check_golden("studio_live", shot(app), ignore=((0, 60, 960, 90), (0, 692, 960, 714)))
    assert player.calls and player.calls[-1].width <= 640
    yaw = app.state.orbit.yaw_deg
    io = imgui.get_io()
    io.add_mouse_pos_event(400.0, 400.0)
    app.frame()
    io.add_mouse_button_event(0, True)
    app.frame()
    for x in (420.0, 460.0, 500.0):
        io.add_mouse_pos_event(x, 400.0)
        app.frame()
    io.add_mouse_button_event(0, False)
    app.frame()
    assert app.state.orbit.yaw_deg != yaw


def test_stage_button_runs_a_stage_and_closing_stops_it(make_app, tiny_project):
    seen = {}

    def forever(project, control, options):
        step = 0
        while True:
            control.check()
            step += 1
            seen["step"] = step
            control.report(Progress("fit", step=step, losses={"kp": 1.0 / step}))
            time.sleep(0.005)

    app = make_app("capture", stages={"fit": forever}, unavailable={})
    app.settle()
    app.press(K._4)
    app.click(50, 72)  # "Fit body", the first stage button
    deadline = time.monotonic() + 10
    while seen.get("step", 0) < 3 and time.monotonic() < deadline:
        app.frame()
        time.sleep(0.01)
    assert seen.get("step", 0) >= 3 and app.worker.latest().state == "running"
    app.close()
    assert not app.worker.alive
    assert app.worker.latest().state in ("stopped", "stopping")


def test_worker_errors_reach_the_status_line(make_app, tiny_project):
    def broken(project, control, options):
        raise ValueError("bad stage input")

    app = make_app("capture", stages={"fit": broken}, unavailable={})
    app.settle()
    app.send(StartStage("fit"))
    deadline = time.monotonic() + 10
    while app.worker.latest().state != "failed" and time.monotonic() < deadline:
        time.sleep(0.01)
    assert app.worker.latest().error == "ValueError: bad stage input"
    check_golden("studio_error_status", shot(app))


def test_fit_residuals_are_read_and_damage_is_an_error(tiny_project):
    from morf.io import save_npz
    from studio.project_view import ProjectView

    view = ProjectView(tiny_project)
    assert view.residuals[3] == 6.0 and 4 not in view.residuals
    assert view.has_fit_overlays() and view.fit_overlay_path(2).name == "000002.jpg"
    save_npz(tiny_project.fits_path, other=np.zeros(3))  # damaged: not through save_fits
    with pytest.raises(MorfError):
        ProjectView(tiny_project)


def test_a_failing_panel_is_reported_and_the_app_goes_on(make_app, tiny_project, monkeypatch):
    import studio.layout

    def broken(state, ui):
        imgui.begin_child("half_done")  # left open: the app must recover imgui's stack
        raise RuntimeError("panel bug")

    panels = list(studio.layout.PANEL_DRAW)
    panels[2] = broken
    monkeypatch.setattr(studio.layout, "PANEL_DRAW", tuple(panels))
    app = make_app("capture")
    app.settle()
    app.press(K._3)
    assert "panel bug" in app.state.note
    app.press(K._1)
    assert app.state.panel == 0
    assert app.frame(capture=True) is not None
