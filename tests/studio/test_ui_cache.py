"""Light UI frames while the live panel plays: the cached window with only the live image redrawn."""

from __future__ import annotations

import numpy as np
import pytest

from test_pacing import PacedPlayer, playing_app


class SamePicturePlayer(PacedPlayer):
    """Draws one gradient for every pose: whichever frame is newest, the picture is the same."""

    def __init__(self):
        super().__init__(delay=0.02)

    def render(self, pose, camera):
        super().render(pose, camera)
        h, w = camera.height, camera.width
        image = np.empty((h, w, 3), np.uint8)
        image[..., 0] = np.linspace(0, 255, w)[None, :]  # red grows to the right, blue to the top
        image[..., 1] = 90
        image[..., 2] = np.linspace(255, 0, h)[:, None]
        return image


def _screen(app) -> np.ndarray:
    fw, fh = app.ctx.screen.viewport[2:]
    data = app.ctx.screen.read(viewport=(0, 0, fw, fh), components=3, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(fh, fw, 3)[::-1]


@pytest.mark.gl
def test_a_light_frame_is_the_last_full_frame_with_the_new_live_image_in_its_place(make_app, tiny_project, tmp_path):
    app = playing_app(make_app, tmp_path, SamePicturePlayer())
    full = app.frame(capture=True)
    rect = app._ui_cache.rect
    assert rect is not None and app._ui_cache.ready(full.shape[1::-1])
    x, y, s = (int(round(v)) for v in (rect.x, rect.y, rect.side))
    # the same live image drawn over the cached frame gives the full frame back
    same = app.textures.preview("live", app.live.latest().image, app.live.latest().seq, ring=3)
    app._ui_cache.show(same)
    np.testing.assert_array_equal(_screen(app), full)
    # a new image changes exactly the live rectangle
    from studio.textures import upload

    tex = upload(app.ctx, np.full((rect.render_side, rect.render_side, 3), (250, 10, 120), np.uint8))
    app._ui_cache.show(tex)
    shot = _screen(app)
    inside = np.zeros(shot.shape[:2], bool)
    inside[y:y + s, x:x + s] = True
    assert (shot[inside] == (250, 10, 120)).all()
    np.testing.assert_array_equal(shot[~inside], full[~inside])
    tex.release()


@pytest.mark.gl
def test_while_a_motion_plays_most_frames_are_light_and_full_frames_keep_coming(make_app, tiny_project, tmp_path):
    app = playing_app(make_app, tmp_path, PacedPlayer(delay=0.03))
    light0, n0, seq0, shown0 = app.light_frame_count, len(app.frame_times), app.live.latest().seq, len(app.live_stats)
    app.run(seconds=2.0)
    light, drawn = app.light_frame_count - light0, len(app.frame_times) - n0
    rendered, shown = app.live.latest().seq - seq0, len(app.live_stats) - shown0
    assert rendered >= 15 and shown >= rendered - 2  # each finished frame still reaches the screen
    assert light >= drawn / 2  # the live image alone, most of the time
    assert drawn - light >= 3  # and the whole UI at least every FULL_FRAME_INTERVAL_S (0.5 s): about 4
    # input makes the next frame a full one
    app._inputs += 1
    assert not app._light_frame_ok()
    app.light_frames = False  # switched off: full frames only
    light0 = app.light_frame_count
    app.run(seconds=0.5)
    assert app.light_frame_count == light0


@pytest.mark.gl
def test_with_a_sub_buffer_light_frames_present_the_rectangle_and_copy_the_ui_once_after_each_swap(
        make_app, tiny_project, tmp_path):
    from studio.sub_buffer import open_sub_buffer

    app = playing_app(make_app, tmp_path, PacedPlayer(delay=0.03))
    assert open_sub_buffer(app.window) is None  # GLFW's null platform: no GLX, light frames swap

    class Recorder:
        def __init__(self):
            self.rects = []

        def present(self, x, y, w, h):
            self.rects.append((x, y, w, h))

    calls = []
    cache = app._ui_cache
    show, draw_image = cache.show, cache.draw_image
    cache.show = lambda image: (calls.append("copy"), show(image))
    cache.draw_image = lambda image: (calls.append("image"), draw_image(image))
    swaps = []
    real_frame = app.frame
    app.frame = lambda *a, **k: (swaps.append(len(calls)), real_frame(*a, **k))[1]
    app._sub_buffer = Recorder()
    app.run(seconds=2.0)
    assert len(app._sub_buffer.rects) >= 10 and len(set(app._sub_buffer.rects)) == 1
    x, y, w, h = app._sub_buffer.rects[0]
    assert w == h == int(round(cache.rect.side))
    # the UI is copied back only on the first light frame after a full frame (a swap); then the image alone
    starts = set(swaps) | {0}  # (the first light frame follows a full frame drawn before the recorder)
    for i, c in enumerate(calls):
        if c == "copy":
            assert i in starts
        else:
            assert i not in starts
    assert calls.count("image") > calls.count("copy") >= 1
