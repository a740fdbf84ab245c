"""The live render's own thread, and a golden screenshot of the panel with a tiny exported avatar."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from morf.camera import PinholeCamera
from screenshots import check_golden
from studio.live_render import LiveRenderer, LiveRequest
from tests.conftest import require

CAM = PinholeCamera.look_at(32, 32, 40.0, (0.0, -3.0, 0.0), (0.0, 0.0, 0.0))


class GatedPlayer:
    """Renders only when the test opens the gate; records what it was asked for."""

    size, num_bones = 32, 104

    def __init__(self):
        self.gate = threading.Event()
        self.entered = threading.Event()
        self.keys = []
        self.released = False

    def render(self, pose, camera):
        self.entered.set()
        self.gate.wait(10)
        self.keys.append(pose)
        return np.full((camera.height, camera.width, 3), len(self.keys), np.uint8)

    def release(self):
        self.released = True


def _wait(cond, timeout=10.0):
    end = threading.Event()
    for _ in range(int(timeout / 0.01)):
        if cond():
            return True
        end.wait(0.01)
    return cond()


def test_requests_are_newest_wins_and_the_player_is_released_on_its_thread():
    player = GatedPlayer()
    lr = LiveRenderer(lambda: (player, None)).start()
    assert lr.wait_open(5) and lr.ready and lr.size == 32
    assert lr.request(LiveRequest("a", CAM, "a"))
    assert player.entered.wait(5) and not lr.idle()
    for k in "bcd":  # posted while "a" renders: only the newest survives
        lr.request(LiveRequest(k, CAM, k))
    assert lr.latest() is None  # the caller never waits for the render
    player.gate.set()
    assert _wait(lambda: lr.idle() and lr.latest() is not None and lr.latest().key == "d")
    assert player.keys == ["a", "d"]
    frame = lr.latest()
    assert frame.seq == 2 and frame.image.shape == (32, 32, 3) and not frame.image.flags.writeable
    assert not lr.request(LiveRequest("d", CAM, "d"))  # same key: not rendered again
    assert _wait(lr.idle) and player.keys == ["a", "d"]
    assert lr.close() and player.released and not lr.alive


def test_a_player_that_cannot_open_or_fails_is_reported_not_raised():
    lr = LiveRenderer(lambda: (None, "avatar folder not found: x")).start()
    assert lr.wait_open(5) and not lr.ready and lr.note == "avatar folder not found: x" and lr.idle()
    lr.close()

    class Broken:
        size = 16

        def render(self, pose, camera):
            raise RuntimeError("bad pose")

    lr = LiveRenderer(lambda: (Broken(), None)).start()
    lr.wait_open(5)
    lr.request(LiveRequest(None, CAM, 1))
    assert _wait(lr.idle)
    assert lr.note == "the player failed: RuntimeError: bad pose" and lr.latest() is None and lr.alive
    lr.close()


class HookedPlayer(GatedPlayer):
    """A GatedPlayer whose rasterization (the part that holds the GIL) ends when ``raster_gate`` opens."""

    def __init__(self):
        super().__init__()
        self.raster_gate = threading.Event()
        self.on_rasterized = None

    def render(self, pose, camera):
        self.entered.set()
        self.raster_gate.wait(10)
        if self.on_rasterized is not None:
            self.on_rasterized()
        return super().render(pose, camera)


def test_the_ui_can_wait_for_the_next_frames_rasterization_only():
    player = HookedPlayer()
    lr = LiveRenderer(lambda: (player, None)).start()
    assert lr.wait_open(5) and player.on_rasterized is not None
    assert lr.wait_rasterized(0.0)  # nothing asked for yet: no wait
    assert lr.request(LiveRequest("a", CAM, "a"))
    assert player.entered.wait(5)
    assert not lr.wait_rasterized(0.05)  # rasterizing: the UI would wait (up to its timeout)
    player.raster_gate.set()
    assert lr.wait_rasterized(5)  # rasterized: the UI draws while the renderer (gated) still runs
    assert lr.latest() is None
    player.gate.set()
    assert _wait(lambda: lr.latest() is not None and lr.latest().key == "a")
    assert not lr.request(LiveRequest("a", CAM, "a")) and lr.wait_rasterized(0.0)  # same key: nothing to wait for
    lr.close()

    plain = GatedPlayer()  # no hook: the wait ends with the render
    plain.gate.set()
    lr = LiveRenderer(lambda: (plain, None)).start()
    lr.wait_open(5)
    lr.request(LiveRequest("b", CAM, "b"))
    assert lr.wait_rasterized(5) and _wait(lambda: lr.latest() is not None)
    lr.close()


class StagedPlayer:
    """Offers the player's two stages; ``complete`` waits for ``shade_gate`` and records what
    overlapped: whether a prepare ran while a frame was shading."""

    size, num_bones = 32, 104

    def __init__(self):
        self.shade_gate = threading.Event()
        self.shading = threading.Event()
        self.prepared, self.completed, self.slots = [], [], []
        self.prepared_while_shading = []
        self.fail_on = None
        self.released = False

    def render(self, pose, camera):  # unused when the thread pipelines
        raise AssertionError("render() called on a staged player")

    def prepare(self, pose, camera, slot):
        self.prepared_while_shading.append((pose, self.shading.is_set()))
        self.prepared.append(pose)
        self.slots.append(slot)
        return pose

    def complete(self, prepared):
        self.shading.set()
        self.shade_gate.wait(10)
        self.shading.clear()
        if prepared == self.fail_on:
            raise RuntimeError("renderer broke")
        self.completed.append(prepared)
        return np.full((32, 32, 3), len(self.completed), np.uint8)

    def release(self):
        self.released = True


def test_a_staged_player_prepares_the_next_frame_while_the_last_one_shades():
    player = StagedPlayer()
    shown = []
    lr = LiveRenderer(lambda: (player, None), on_frame=lambda: shown.append(lr.latest()))
    assert lr.start().wait_open(5) and lr.pipelined
    assert lr.request(LiveRequest("a", CAM, "a"))
    assert _wait(player.shading.is_set)  # "a" shades (gated)
    assert lr.request(LiveRequest("b", CAM, "b"))
    assert lr.wait_rasterized(5)  # "b" is prepared at once, while "a" still shades
    assert player.prepared_while_shading[-1] == ("b", True) and lr.latest() is None
    # both buffers are taken ("a" shading, "b" waiting): "c" waits, and the UI is not made to wait for it
    assert lr.request(LiveRequest("c", CAM, "c"))
    assert lr.wait_rasterized(0.0) and player.prepared == ["a", "b"]
    lr.request(LiveRequest("d", CAM, "d"))  # newest wins over "c"
    player.shade_gate.set()
    assert _wait(lambda: lr.idle() and lr.latest() is not None and lr.latest().key == "d")
    assert player.prepared == ["a", "b", "d"] and player.completed == ["a", "b", "d"]
    assert player.slots == [0, 1, 0]  # "d" reused "a"'s buffer, which had been shown
    keys = [f.key for f in shown if f is not None]
    assert keys == sorted(set(keys)) and keys[-3:] == ["a", "b", "d"]  # each frame shown, in order
    frame = lr.latest()
    assert frame.seq == 3 and frame.latency_ms >= frame.render_ms * 0.5 and not frame.image.flags.writeable
    assert lr.close() and player.released and not lr.alive


def test_a_pipelined_frame_that_fails_is_reported_and_the_next_one_shown():
    player = StagedPlayer()
    player.fail_on = "a"
    player.shade_gate.set()
    lr = LiveRenderer(lambda: (player, None)).start()
    lr.wait_open(5)
    lr.request(LiveRequest("a", CAM, "a"))
    assert _wait(lr.idle)
    assert lr.note == "the player failed: RuntimeError: renderer broke" and lr.latest() is None
    lr.request(LiveRequest("b", CAM, "b"))
    assert _wait(lambda: lr.latest() is not None and lr.latest().key == "b") and lr.note is None
    lr.close()


def test_pipelining_can_be_turned_off():
    player = StagedPlayer()
    player.shade_gate.set()
    player.render = lambda pose, camera: np.zeros((32, 32, 3), np.uint8)
    lr = LiveRenderer(lambda: (player, None), pipelined=False).start()
    lr.wait_open(5)
    lr.request(LiveRequest("a", CAM, "a"))
    assert _wait(lambda: lr.latest() is not None) and not lr.pipelined and player.prepared == []
    lr.close()


@pytest.mark.gl
def test_live_panel_golden_with_a_tiny_exported_avatar(make_app, tiny_project, tiny_avatar_dir):
    import shutil

    imgui = require("imgui_bundle").imgui

    shutil.copytree(tiny_avatar_dir, tiny_project.avatar_dir)
    app = make_app("capture", unavailable={})
    assert app.live is not None and app.live.wait_open(30) and app.live.ready, app.live.note
    app.settle()
    app.press(imgui.Key._5)
    app.settle()  # waits until the render thread delivered this pose and camera
    frame = app.live.latest()
    assert frame is not None and frame.image.shape == (640, 640, 3)
    img = app.frame(capture=True)
    # the fps overlay and the timing line vary from run to run: blank them
    check_golden("studio_live_avatar", img, ignore=((0, 60, 960, 90), (0, 692, 960, 714)))
    assert frame.image.std() > 5.0  # the avatar is on screen, not a flat image


@pytest.mark.gl
def test_the_playback_players_two_stages_give_its_render(tiny_avatar_dir):
    from studio.orbit import OrbitCamera
    from studio.player import open_live_player

    player, note = open_live_player(tiny_avatar_dir)
    assert player is not None, note
    try:
        cam = OrbitCamera().camera(640, 640)
        whole = player.render(None, cam)
        first = player.prepare(None, cam, 0)
        second = player.prepare(None, cam, 1)  # the other buffer: the first stays valid
        assert np.array_equal(player.complete(first), whole) and np.array_equal(player.complete(second), whole)
        assert whole.std() > 5.0
    finally:
        player.release()
