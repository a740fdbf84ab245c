"""The web player in real headless Chromium (SwiftShader WebGL, onnxruntime-web WASM): the page
loads with no console errors and plays a motion; a frame matches the Python player's frame for the
same pose and camera over the person; the tail in JavaScript and in WebGL agree; without the
isolation headers it falls back to one thread and says so; a render against a golden image."""

from __future__ import annotations

import base64
import dataclasses
import io

import numpy as np
import pytest

pytestmark = pytest.mark.gl

MIN_PERSON_PSNR_DB = 30.0  # the page against the Python player, over the person (the bar)


def _image(b64: str) -> np.ndarray:
    a = np.frombuffer(base64.b64decode(b64), np.uint8)
    s = int(round(np.sqrt(a.size // 4)))
    return a.reshape(s, s, 4)[..., :3].copy()


def _png(data_url: str) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data_url.split(",", 1)[1]))).convert("RGB"))


def _frames(num_bones: int, size: int, count: int = 2, seed: int = 3):
    from morf.raster.camera_paths import front_camera

    rng = np.random.default_rng(seed)
    out = []
    for k in range(count):
        rot = (rng.normal(size=(num_bones, 3)) * 0.12).astype(np.float32)
        rot[0] = (0.0, 0.0, 0.6 * k)
        out.append((rot, np.array([0.05, 0.0, 0.02 * k], np.float32), front_camera(size, yaw_deg=20.0 * k)))
    return out


def _drawn(avatar, mesh: str):
    """The exported avatar with the mesh the page drew (``mesh``: "full" or a level of the web
    folder's, morf/web/light_mesh.py)."""
    import dataclasses

    from morf.export.avatar_folder import load_exported_avatar
    from morf.web.light_mesh import light_meshes
    from morf.web.web_avatar import LEVEL_NAMES

    a = load_exported_avatar(avatar)
    if mesh == "full":
        return a
    levels = light_meshes(a.mesh, a.skeleton.names, a.skeleton.parents)
    return dataclasses.replace(a, mesh=levels[LEVEL_NAMES.index(mesh)].mesh)


def _faces(folder, mesh: str) -> int:
    """The triangle count of ``mesh`` in the web folder's avatar.json."""
    import json

    doc = json.loads((folder.path / "avatar" / "avatar.json").read_text())["mesh"]
    return doc["faces"] if mesh == "full" else next(lv["faces"] for lv in doc["levels"] if lv["name"] == mesh)


def _python_frames(avatar, frames, size, precision):
    """The Python player's images and the body's pixels (the raster's coverage) of ``frames``, with
    the renderer the page runs (``precision``: the web folder plays fp32 where the export measured
    int8 under 30 dB from it, as morf play does)."""
    from morf.playback.player import Player

    with Player(avatar, size=size, precision=precision) as p:
        images = [p.render(r, t, c) for r, t, c in frames]
        person = [p.rasterize(r, t, c).reshape(size, size, 16)[..., 0] != 128 for r, t, c in frames]
    return images, person


def test_page_loads_without_console_errors_and_plays_a_motion(tiny_web):
    from morf.web.browser import run_page

    r = run_page(tiny_web.path, "report=8&size=128&motion=walk_in_place", timeout=240)
    assert "error" not in r, r.get("error")
    assert r["messages"] == []
    assert r["motion"] == "walk_in_place" and r["playing"]
    assert len(set(r["frames"])) >= 3, r["frames"]  # the motion's frames advance
    assert r["isolated"] and r["threads"] >= 2 and r["backend"] == "wasm"
    assert all(line.endswith((" 200", " 204", " 304")) for line in r["requests"]), r["requests"]
    img = _image(r["image"])
    assert (np.abs(img.astype(int) - 255).max(-1) > 8).mean() > 0.01  # a body on the white background


@pytest.mark.parametrize("mesh", ["full", "auto"])
def test_frame_matches_the_python_player_whole_graph(tiny_web, tiny_avatar, mesh):
    """With the full mesh, and with the page's own choice on software WebGL at these full-body
    views: a lighter level (each against the Python player drawing the same mesh)."""
    from morf.web.check import page_frames, psnr

    size = 256
    frames = _frames(104, size)
    page, info = page_frames(tiny_web.path, frames, query="" if mesh == "auto" else f"mesh={mesh}")
    assert (info["mesh"] == "full") == (mesh == "full"), info["mesh"]
    assert info["triangles"] == _faces(tiny_web, info["mesh"])
    want, person = _python_frames(_drawn(tiny_avatar, info["mesh"]), frames, size, tiny_web.precision)
    assert info["messages"] == [] and info["renderer"]["mode"] == "image"
    for a, b, m, w in zip(page, want, person, info["windows"]):
        assert m.sum() > 2000
        assert psnr(a, b, m) >= MIN_PERSON_PSNR_DB, psnr(a, b, m)
        # the renderer ran on the person's window, not the whole frame, and the body lies inside it
        assert w["w"] * w["h"] < size * size, w
        ys, xs = np.nonzero(m)
        assert w["x"] <= xs.min() and xs.max() < w["x"] + w["w"] and w["y"] <= ys.min() and ys.max() < w["y"] + w["h"], w


def test_webgpu_frame_matches_the_python_player(tiny_avatar, tmp_path):
    """The --webgpu folder in Chromium's WebGPU (SwiftShader's software adapter here): skipped where
    that Chromium offers no WebGPU adapter (the page then falls back to WASM)."""
    from morf.web.build import build_web_folder
    from morf.web.check import page_frames, psnr

    folder = build_web_folder(tiny_avatar, tmp_path / "gpu", webgpu=True)
    size = 256
    frames = _frames(104, size)
    page, info = page_frames(folder.path, frames, query="backend=webgpu&mesh=full", webgpu=True, timeout=300)
    if info["backend"] != "webgpu":
        pytest.skip("this Chromium offers the page no WebGPU adapter")
    want, person = _python_frames(tiny_avatar, frames, size, folder.precision)
    assert info["messages"] == []
    for a, b, m in zip(page, want, person):
        assert psnr(a, b, m) >= MIN_PERSON_PSNR_DB, psnr(a, b, m)


def test_raster_renderer_and_tail_match_the_python_player(tail_web, tail_avatar):
    """The cpu preset's renderer (random weights): onnxruntime-web runs the graph cut before its tail
    and the page plays the tail, in JavaScript (SwiftShader's choice) and in WebGL passes, the
    mesh skinned in JavaScript and in the vertex shader.

    Checked stage by stage: the page's raster against the Python player's GL raster, and the page's
    image against the Python player's renderer + compiled tail run on the page's own raster. (Whole
    frames of a random renderer are no fair check: it turns the few pixels where two rasterizers
    break a tie on a texture seam differently into streaks; the trained demo avatar's frames agree
    at 41-43 dB over the person, docs/web.md.)"""
    import json

    from morf.playback.player import Player
    from morf.web.check import page_frames
    from morf.web.page_fill import fill_pyramid

    size = 128
    frames = _frames(104, size)
    # software WebGL skins on the CPU (with the JavaScript tail, a lighter level at these views); the
    # GPU's vertex-shader skinning with the passes and the full mesh
    spec = json.loads((tail_web.path / "avatar" / "avatar.json").read_text())["renderer"]["tail"]
    assert spec["fill_levels"] == 6  # the page computes the colour fill (morf/web/page_fill.py)
    for tail, skin, mesh in (("js", "cpu", "auto"), ("webgl", "gpu", "full")):
        page, info = page_frames(tail_web.path, frames, query=f"tail={tail}&skin={skin}&mesh={mesh}", rasters=True,
                                 outputs=True)
        assert info["messages"] == [] and info["renderer"]["mode"] == "tail" and info["tail"] == tail
        for raster, outputs in zip(info["rasters"], info["outputs"]):  # the page's fill, the Python one's
            want = fill_pyramid(raster, spec["colour_scale"], spec["zero_point"], spec["coverage_channel"], 6)
            assert np.abs(outputs[spec["fill"]][0] - want).max() <= 1e-5
        assert (info["mesh"] == "full") == (mesh == "full"), info["mesh"]
        drawn = _drawn(tail_avatar, info["mesh"])
        with Player(drawn, size=size, precision=tail_web.precision, raster="gl") as p:
            for (r, t, c), image, raster in zip(frames, page, info["rasters"]):
                want = p.rasterize(r, t, c).reshape(size, size, 16).astype(np.int16)
                body = want[..., 0] != 128
                assert ((raster[..., 0] != 128) ^ body).sum() <= 0.01 * body.sum()
                # two software rasterizers (SwiftShader, llvmpipe) interpolate texture coordinates a
                # little differently: on this steep 64 x 64 texture 94 % of the bytes agree within 1
                d = np.abs(raster.astype(np.int16) - want)[body]
                assert (d <= 1).mean() >= 0.9 and d.mean() <= 1.0, ((d <= 1).mean(), d.mean())
                same = p.shade(raster[None].copy())  # the renderer + tail on the page's raster
                d = np.abs(image.astype(np.int16) - same)
                assert d.max() <= 2 and (d > 0).mean() <= 1e-3, (tail, d.max(), (d > 0).mean())


def test_without_isolation_one_thread_and_says_so(tiny_web):
    from morf.web.browser import run_page

    r = run_page(tiny_web.path, "report=2&size=64", isolation=False, timeout=240)
    assert "error" not in r, r.get("error")
    assert not r["isolated"] and r["threads"] == 1
    assert "one thread" in r["status"] and "cross-origin isolation" in r["status"]
    assert r["messages"] == []


def test_output_size_adapts_and_says_so(tiny_web):
    """Under the target rate the page picks a smaller output and says why (target=1000: a rate no
    machine holds, so the test does not depend on this one's speed)."""
    from morf.web.browser import run_page

    r = run_page(tiny_web.path, "report=24&target=1000&motion=idle_sway", timeout=300)
    assert "error" not in r and r["messages"] == []
    assert r["size"] < 640 and r["size"] % 8 == 0
    assert "under 1000" in r["notice"] and f"Output {r['size']} × {r['size']} px" in r["notice"], r["notice"]


def test_output_size_grows_back_without_see_sawing(tiny_web):
    """The adaptive size's decisions (adaptive.js) for scripted measurements: it shrinks under the
    target, grows one step only with room to spare after a longer stretch, and a size it just
    failed at is retried only after a wait that doubles with each failure there."""
    import json

    from morf.web.browser import run_page

    script = [(10, 25, 0),        # 640 at 10 fps: down to 320 (the pixel count 10 fps holds at 30)
              (45, 100, 1000),    # 320 at 45 fps: 384 would run 31 fps, too close to 30: stay
              (60, 59, 2000),     # room, but not yet seen long enough
              (60, 60, 2000),     # room: up to 384
              (25, 20, 3000),     # 384 fails: back to 320, 384 not retried for 5 s
              (60, 60, 4000),     # room, but 384 failed a second ago
              (60, 60, 8000),     # 5 s later: 384 again
              (25, 20, 9000),     # fails again: back to 320, now for 10 s
              (60, 60, 15000),    # still waiting
              (60, 60, 19000)]    # 10 s later: 384
    r = run_page(tiny_web.path, "size=640&policy=" + json.dumps(script).replace(" ", ""), timeout=240)
    assert "error" not in r and r["messages"] == [], r.get("error")
    assert r["target"] == 30 and {640, 384, 320} <= set(r["sizes"]), r["sizes"]
    moves = [(d["size"], d["step"]["to"] if d["step"] else None) for d in r["steps"]]
    assert moves == [(640, 320), (320, None), (320, None), (320, 384), (384, 320), (320, None), (320, 384),
                     (384, 320), (320, None), (320, 384)], moves
    assert [d["step"]["why"] for d in r["steps"] if d["step"]] == ["slow", "headroom", "slow", "headroom", "slow", "headroom"]


def test_output_size_grows_on_a_fast_device_and_says_so(tiny_web):
    """Started small with a target any machine holds (target=1), the page grows its output and says why."""
    from morf.web.browser import run_page

    r = run_page(tiny_web.path, "report=75&start=128&target=1&motion=idle_sway", timeout=300)
    assert "error" not in r and r["messages"] == [], r.get("error")
    assert r["adapted"] and r["adapted"]["why"] == "headroom" and r["adapted"]["from"] == 128, r["adapted"]
    to = r["adapted"]["to"]
    assert to > 128 and f"Output {to} × {to} px" in r["notice"] and "room for a larger output" in r["notice"], r["notice"]


def test_golden_render(tiny_web):
    from morf.web.browser import run_page
    from tests.studio.screenshots import check_golden

    r = run_page(tiny_web.path, "report=1&size=128&motion=walk_in_place&frame=12&pause=1", timeout=240)
    assert "error" not in r and r["frames"] == [12] and not r["playing"]
    canvas = _png(r["canvas"])  # what the page shows: the image, upright
    assert np.array_equal(canvas, _image(r["image"]))
    check_golden("web_tiny_walk_in_place_12", canvas, tolerance=0.01)


def test_tail_in_javascript_shows_its_image_on_a_2d_canvas(tail_web):
    """The JavaScript tail's image goes onto the page's canvas as a 2D canvas (the window put over
    the background): what the canvas shows is the composited image; with ?canvas=gl the same image
    comes through the WebGL canvas."""
    from morf.web.browser import run_page

    shown = {}
    for canvas in ("2d", "gl"):
        r = run_page(tail_web.path, f"report=1&size=256&motion=walk_in_place&frame=5&pause=1&canvas={canvas}", timeout=240)
        assert "error" not in r and r["messages"] == [] and r["tail"] == "js", r.get("error")
        assert r["window"]["w"] * r["window"]["h"] < 256 * 256, r["window"]
        shown[canvas] = _png(r["canvas"])
        assert np.array_equal(shown[canvas], _image(r["image"])), canvas
    assert (np.abs(shown["2d"].astype(int) - 255).max(-1) > 8).mean() > 0.01  # a body on the white background


def test_view_colours_are_drawn_as_the_python_player_draws_them(tiny_avatar, tmp_path):
    """An avatar with view colours (four anchors, each a different flat green and blue over the
    texture's own channel 0): the page blends them per frame as the Python player does. The page
    drawing the one texture instead would miss by far more than the bar."""
    import json
    import shutil

    from morf.avatar.view_colour import ViewColourBytes
    from morf.export.avatar_folder import MANIFEST, load_exported_avatar, write_manifest, write_view_colours
    from morf.rotations import rotvec_to_matrix_rodrigues
    from morf.web.build import build_web_folder
    from morf.web.check import page_frames, psnr
    from tests.web.conftest import browser_or_skip

    browser_or_skip()
    avatar = tmp_path / "avatar"
    shutil.copytree(tiny_avatar, avatar)
    tex = load_exported_avatar(avatar).texture.data
    anchors = rotvec_to_matrix_rodrigues(np.array([[0, 0, 0], [0, 0, 0.6], [0, 1.2, 0], [1.0, 0, 0.4]], float))
    colours = np.stack([np.dstack([tex[..., 0], np.full(tex.shape[:2], 60 + 50 * k, np.uint8),
                                   np.full(tex.shape[:2], 230 - 50 * k, np.uint8)]) for k in range(4)])
    write_view_colours(avatar, ViewColourBytes(anchors.astype(np.float32), colours))
    fields = {k: v for k, v in json.loads((avatar / MANIFEST).read_text()).items()
              if k not in ("format", "version", "files")}
    write_manifest(avatar, fields)
    folder = build_web_folder(avatar, tmp_path / "web")
    doc = json.loads((folder.path / "avatar" / "avatar.json").read_text())
    assert doc["view_colours"]["count"] == 4 and (folder.path / "avatar" / "view_colours.bin").is_file()
    size = 256
    frames = _frames(104, size, count=3)
    page, info = page_frames(folder.path, frames, query="mesh=full")
    want, person = _python_frames(avatar, frames, size, folder.precision)
    plain, _ = _python_frames(_without_views(avatar), frames, size, folder.precision)
    assert info["messages"] == []
    for a, b, c, m in zip(page, want, plain, person):
        assert psnr(a, b, m) >= MIN_PERSON_PSNR_DB, psnr(a, b, m)
        assert psnr(c, b, m) < MIN_PERSON_PSNR_DB - 5  # the view colours change the image


def _without_views(folder):
    import dataclasses

    from morf.export.avatar_folder import load_exported_avatar

    return dataclasses.replace(load_exported_avatar(folder), view_colours=None)


def test_head_colours_are_laid_over_as_the_python_player_lays_them(tiny_avatar, body_model, tmp_path):
    """An avatar whose view colours carry the head's own colours (five head anchors, each a flat red
    laid over by the real head share, the neck's partial shares included): the page blends them by
    the head bone's orientation and lays them over as the Python player does; without them the
    image differs by far more than the bar."""
    import json
    import shutil

    from morf.avatar.head_colour import HeadColourBytes, head_share
    from morf.avatar.view_colour import ViewColourBytes
    from morf.export.avatar_folder import MANIFEST, load_exported_avatar, write_manifest, write_view_colours
    from morf.rotations import rotvec_to_matrix_rodrigues
    from morf.web.build import build_web_folder
    from morf.web.check import page_frames, psnr
    from tests.web.conftest import browser_or_skip

    browser_or_skip()
    avatar = tmp_path / "avatar"
    shutil.copytree(tiny_avatar, avatar)
    loaded = load_exported_avatar(avatar)
    tex = loaded.texture.data
    anchors = rotvec_to_matrix_rodrigues(np.array([[0, 0, 0], [0, 0, 0.6], [0, 1.2, 0]], float)).astype(np.float32)
    body = np.stack([np.dstack([tex[..., 0], np.full(tex.shape[:2], 60 + 50 * k, np.uint8),
                                np.full(tex.shape[:2], 230 - 50 * k, np.uint8)]) for k in range(3)])
    share = np.rint(head_share(body_model, tex.shape[0]).reshape(-1) * 255)
    texels = np.flatnonzero(share >= 1).astype(np.int32)
    assert 0 < (share[texels] < 255).sum() < len(texels)
    turns = np.array([[0, 0, 0], [0, 0, 0.6], [0, 1.2, 0], [1.0, 0, 0.4], [0, -1.2, 0]], float)
    head_anchors = rotvec_to_matrix_rodrigues(turns).astype(np.float32)  # more than the three blended
    head_rgb = np.stack([np.tile(np.array([[240, 20 + 50 * k, 30]], np.uint8), (len(texels), 1)) for k in range(5)])
    bone = list(loaded.skeleton.names).index("head")
    head = HeadColourBytes(head_anchors, bone, texels, share[texels].astype(np.uint8), head_rgb)
    write_view_colours(avatar, ViewColourBytes(anchors, body, head))
    fields = {k: v for k, v in json.loads((avatar / MANIFEST).read_text()).items()
              if k not in ("format", "version", "files")}
    write_manifest(avatar, fields)
    assert load_exported_avatar(avatar).view_colours.head.bone == bone
    folder = build_web_folder(avatar, tmp_path / "web")
    doc = json.loads((folder.path / "avatar" / "avatar.json").read_text())
    assert doc["view_colours"]["head"]["count"] == 5 and doc["view_colours"]["head"]["texels"] == len(texels)
    size = 256
    frames = _frames(104, size, count=3)
    for rot, _, _ in frames:
        rot[bone] = (0.0, 0.9, 0.0)  # the head turned on its own
    page, info = page_frames(folder.path, frames, query="mesh=full")
    want, person = _python_frames(avatar, frames, size, folder.precision)
    without = dataclasses.replace(load_exported_avatar(avatar), view_colours=ViewColourBytes(anchors, body))
    plain, _ = _python_frames(without, frames, size, folder.precision)
    heads = _head_pixels(avatar, without, frames, size)
    assert info["messages"] == []
    for a, b, c, m, h in zip(page, want, plain, person, heads):
        assert h.sum() > 100
        assert psnr(a, b, m) >= MIN_PERSON_PSNR_DB, psnr(a, b, m)
        assert psnr(a, b, h) >= MIN_PERSON_PSNR_DB, psnr(a, b, h)  # the head itself, where a wrong blend shows
        assert psnr(c, b, m) < MIN_PERSON_PSNR_DB - 5  # the head's colours change the image


def _head_pixels(avatar, without, frames, size):
    """Per frame, the pixels whose renderer input differs between ``avatar`` and ``without``."""
    from morf.playback.player import Player

    inputs = []
    for a in (avatar, without):
        with Player(a, size=size) as p:
            inputs.append([p.rasterize(r, t, c).reshape(size, size, 16)[..., :3].copy() for r, t, c in frames])
    return [np.any(x != y, axis=-1) for x, y in zip(*inputs)]
