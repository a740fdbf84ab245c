"""When the studio redraws: the pacing rule on a fake clock, and the real frame loop headless."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from studio.pacing import FramePacer, Wakeup
from studio.snapshot import Mailbox, Snapshot

MOTION = "resources/motions/walk_forward.npz"


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_idle_redraws_at_the_idle_rate_and_changes_at_once_but_never_above_the_cap():
    clock = Clock()
    p = FramePacer(max_fps=50, idle_fps=4, settle_frames=2, clock=clock)
    assert p.wait_s() == 0.0  # the first frame is due at once
    p.frame_started()
    assert p.wait_s() == pytest.approx(0.25)  # nothing happens: the idle rate
    clock.t += 0.005
    p.want_within(0.0)  # a live frame arrived 5 ms after the last frame started
    assert p.wait_s() == pytest.approx(0.015)  # the cap: 20 ms between frames
    clock.t += 0.015
    p.frame_started()
    assert p.wait_s() == pytest.approx(0.25)  # a change asks for one frame, not more
    p.want_within(0.1)  # a snapshot: within 100 ms
    assert p.wait_s() == pytest.approx(0.1)


def test_input_draws_settle_frames_at_the_cap():
    clock = Clock()
    p = FramePacer(max_fps=50, idle_fps=4, settle_frames=2, clock=clock)
    p.frame_started()
    clock.t += 0.1
    p.input()
    assert p.wait_s() == 0.0
    waits = []
    for _ in range(4):
        p.frame_started()
        waits.append(round(p.wait_s(), 4))
        clock.t += p.wait_s()
    assert waits == [0.02, 0.02, 0.25, 0.25]  # the input's frame, then two settle frames, then idle


def test_no_cap_means_no_waiting():
    p = FramePacer(max_fps=0, clock=Clock())
    p.frame_started()
    assert p.continuous and p.wait_s() == 0.0


def test_wakeup_ends_a_wait_from_another_thread_and_keeps_the_most_urgent_request():
    pokes = []
    w = Wakeup(lambda: pokes.append(1))
    threading.Timer(0.05, lambda: (w.notify(0.1), w.notify(0.0))).start()
    t0 = time.perf_counter()
    w.wait(5.0)
    assert time.perf_counter() - t0 < 2.0
    time.sleep(0.02)  # both notifications are in
    assert w.take() == 0.0 and w.take() is None and len(pokes) == 2
    w.disconnect()
    w.notify()
    assert len(pokes) == 2


def test_a_mailbox_calls_its_listener_after_each_publish():
    seen = []
    box = Mailbox(on_publish=lambda: seen.append(box.latest().seq))
    box.publish(Snapshot(seq=3))
    assert seen == [3]


class PacedPlayer:
    """Takes ``delay`` seconds a frame, like a real player; counts its renders."""

    size, num_bones = 64, 104

    def __init__(self, delay: float):
        self.delay, self.renders = delay, 0

    def render(self, pose, camera):
        time.sleep(self.delay)
        self.renders += 1
        return np.full((camera.height, camera.width, 3), 40 * (self.renders % 5), np.uint8)


def playing_app(make_app, tmp_path, player):
    """The tiny project's studio on the live panel, ``player`` playing the shipped walk, its first
    frames on screen."""
    app = headless_app(make_app, tmp_path, idle_fps=2.0)
    app.show_player(player)
    app.state.select_panel(4)
    app.state.motion_file = str(Path(__file__).resolve().parents[2] / MOTION)
    app.state.playing = True
    for _ in range(60):  # the motion loads, the first frames arrive
        app.run(seconds=0.5)
        if app.live_panel.clip is not None and app.live.latest() is not None:
            break
    assert app.live.latest() is not None and app.live_panel.clip is not None
    return app


def headless_app(make_app, tmp_path, **kw):
    """The tiny project in a studio that measures real frame times (no fixed frame time)."""
    return make_app("capture", deterministic=False, unavailable={}, motion_dir=str(tmp_path), **kw)


@pytest.mark.gl
def test_the_idle_studio_redraws_a_few_times_a_second_and_continuous_mode_as_fast_as_it_can(make_app, tiny_project,
                                                                                             tmp_path):
    app = headless_app(make_app, tmp_path, idle_fps=5.0)
    app.settle()
    n = len(app.frame_times)
    app.run(seconds=1.0)
    assert 2 <= len(app.frame_times) - n <= 9  # about 5: the idle rate (a first frame, timing slack)
    app.close()  # one studio at a time: imgui's backends are process-wide
    fast = headless_app(make_app, tmp_path, max_fps=0)
    fast.settle()
    n = len(fast.frame_times)
    fast.run(seconds=1.0)
    assert len(fast.frame_times) - n > 12  # every loop iteration draws


@pytest.mark.gl
def test_a_playing_motion_redraws_when_a_live_frame_arrives_and_shows_each_one(make_app, tiny_project, tmp_path):
    app = playing_app(make_app, tmp_path, PacedPlayer(delay=0.08))
    n, seq0, shown0 = len(app.frame_times), app.live.latest().seq, len(app.live_stats)
    app.run(seconds=2.0)
    rendered, shown, drawn = app.live.latest().seq - seq0, len(app.live_stats) - shown0, len(app.frame_times) - n
    assert rendered >= 10  # about 12 a second: the render thread hardly waits for the UI
    assert shown >= rendered - 2  # each finished frame reaches the screen
    assert drawn <= rendered + 2 * 2.0 + 3  # one UI frame per live frame, plus idle ticks: not 60 a second
