"""The Player on a tiny exported avatar: a person appears where the body is, in every mode."""

import numpy as np
import pytest

from morf.errors import InputError
from morf.playback.player import Player
from morf.raster.camera_paths import front_camera

SIZE = 128  # as in conftest.py


def test_renders_a_person(tiny_avatar, still_pose):
    rot, tr = still_pose
    with Player(tiny_avatar, size=SIZE, background=(0, 0, 255)) as p:
        img = p.render(rot, tr, front_camera(SIZE))
        raster = p.rasterize(rot, tr, front_camera(SIZE))
        assert set(p.last_timings) >= {"bones_ms", "raster_ms", "readback_ms", "layout_ms", "renderer_ms"}
        assert p.avatar.input_layout == "nhwc" and raster.shape == (1, SIZE, SIZE, 16)
    assert img.shape == (SIZE, SIZE, 3) and img.dtype == np.uint8
    covered = raster[0, ..., 0] > 200  # coverage channel: 255 on the body, 128 elsewhere
    person = ~((img[..., 0] < 8) & (img[..., 1] < 8) & (img[..., 2] > 247))
    assert 0.03 < covered.mean() < 0.5
    assert (person == covered).mean() > 0.98
    assert img[covered].std() > 5  # textured, not a flat fill


def test_the_rasterized_hook_runs_between_the_gl_work_and_the_renderer(tiny_avatar, still_pose):
    rot, tr = still_pose
    calls = []
    with Player(tiny_avatar, size=SIZE) as p:
        rasterize, shade = p.rasterize, p.shade
        p.rasterize = lambda *a, **k: calls.append("raster") or rasterize(*a, **k)
        p.shade = lambda x: calls.append("shade") or shade(x)
        img = p.render(rot, tr, front_camera(SIZE), on_rasterized=lambda: calls.append("hook"))
        assert calls == ["raster", "hook", "shade"]
        assert np.array_equal(img, p.render(rot, tr, front_camera(SIZE)))  # the same image without it


def test_texture_sequence_and_fp32_agree(tiny_avatar, still_pose):
    rot, tr = still_pose
    cams = [front_camera(SIZE, yaw_deg=a) for a in (0, 40, 80)]
    with Player(tiny_avatar, size=SIZE) as p:
        single = [p.render(rot, tr, c) for c in cams]
        piped = list(p.render_sequence((rot, tr, c) for c in cams))
        tex = p.render_texture(rot, tr, cams[0])
        from_tex = np.frombuffer(tex.read(), np.uint8).reshape(SIZE, SIZE, 3)
    for a, b in zip(single, piped):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(from_tex, single[0])
    with Player(tiny_avatar, size=SIZE, precision="fp32") as p32:
        f = p32.render(rot, tr, cams[0]).astype(np.float32)
    mse = np.mean((f - single[0]) ** 2) / 255.0 ** 2
    assert -10 * np.log10(max(mse, 1e-12)) > 35


def test_the_two_stages_make_the_rendered_image_and_a_prepared_frame_keeps_its_own_buffer(tiny_avatar, still_pose):
    rot, tr = still_pose
    cams = [front_camera(SIZE, yaw_deg=a) for a in (0, 90)]
    with Player(tiny_avatar, size=SIZE) as p:
        single = [p.render(rot, tr, c) for c in cams]
        bufs = [p.new_input(), p.new_input()]
        first = p.prepare(rot, tr, cams[0], out=bufs[0])
        second = p.prepare(rot, tr, cams[1], out=bufs[1])  # prepared before the first completes
        assert first.raster is bufs[0] and second.raster is bufs[1] and first.box is None
        np.testing.assert_array_equal(p.complete(first), single[0])
        np.testing.assert_array_equal(p.complete(second), single[1])


def test_bad_size_is_a_user_error(tiny_avatar):
    with pytest.raises(InputError):
        Player(tiny_avatar, size=100)


def test_other_input_layouts_and_image_backgrounds_play_the_same(tiny_avatar, still_pose, tmp_path, body_model):
    """An avatar exported with the channels-first layout renders the same image; an image
    background composites like the same plain colour."""
    from types import SimpleNamespace

    from morf.export.synthetic import build_synthetic_avatar, coverage_renderer, coverage_texture

    nchw = tmp_path / "nchw"
    build_synthetic_avatar(nchw, body_model=body_model, renderer=coverage_renderer(), texture=coverage_texture(),
                           image_size=64, calibration_views=3, heldout_views=1, input_layout="nchw",
                           renderer_cfg=SimpleNamespace(in_channels=16))
    rot, tr = still_pose
    cam = front_camera(SIZE, yaw_deg=20)
    colour = (30, 140, 220)
    with Player(tiny_avatar, size=SIZE, background=colour, precision="fp32") as a, \
            Player(nchw, size=SIZE, background=colour, precision="fp32") as b:
        img_a = a.render(rot, tr, cam)
        assert b.avatar.input_layout == "nchw" and b.rasterize(rot, tr, cam).shape == (1, 16, SIZE, SIZE)
        np.testing.assert_array_equal(img_a, b.render(rot, tr, cam))
        a.background = np.broadcast_to(np.array(colour, np.uint8), (SIZE, SIZE, 3))
        np.testing.assert_array_equal(img_a, a.render(rot, tr, cam))
        with pytest.raises(InputError, match="background"):
            a.background = np.zeros((SIZE // 2, SIZE, 3), np.uint8)


def test_views_closer_than_the_trained_scale_are_drawn_through_it(tiny_avatar, still_pose):
    """The avatar folder records its largest training scale; a closer camera is drawn as a wider
    view at that scale and the asked part enlarged (the renderer's mask breaks up beyond it)."""
    from morf.raster.view_scale import MARGIN, enlarge, pixels_per_metre

    rot, tr = still_pose
    close = front_camera(SIZE, distance=1.2)
    with Player(tiny_avatar, size=SIZE, background=(0, 0, 255)) as p:
        p.max_pixels_per_metre = None  # no recorded scale: drawn as asked
        assert p.view(tr, close) == (close, None)
        direct = p.render(rot, tr, close)
        p.max_pixels_per_metre = pixels_per_metre(close, tr) / (2.0 * MARGIN)
        cam, box = p.view(tr, close)
        assert box is not None and abs(cam.fy * 2.0 - close.fy) < 1e-6
        img = p.render(rot, tr, close)
        np.testing.assert_array_equal(img, enlarge(p.shade(p.rasterize(rot, tr, cam)), box))
        assert not np.array_equal(img, direct)
        p.background = np.zeros((SIZE, SIZE, 3), np.uint8)  # an image background is not enlarged
        assert p.view(tr, close)[1] is None
