"""The live image put straight into an X window (studio.x_image), on a private Xvfb server."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(shutil.which("Xvfb") is None, reason="needs Xvfb (apt-get install xvfb)")

READ_BACK = textwrap.dedent("""
    import ctypes, ctypes.util
    import glfw, numpy as np
    from studio.x_image import _XImage

    def read_window(window, x, y, n):
        # the (n, n, 3) RGB pixels the X server holds at window pixel (x, y)
        x11 = ctypes.CDLL(ctypes.util.find_library("X11"))
        x11.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
        x11.XGetImage.restype = ctypes.POINTER(_XImage)
        x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int, ctypes.c_uint,
                                  ctypes.c_uint, ctypes.c_ulong, ctypes.c_int]
        display, xwindow = glfw.get_x11_display(), glfw.get_x11_window(window)
        x11.XSync(display, 0)
        got = x11.XGetImage(display, xwindow, x, y, n, n, 0xFFFFFFFF, 2).contents
        raw = np.ctypeslib.as_array(ctypes.cast(got.data, ctypes.POINTER(ctypes.c_uint8)), (n, got.bytes_per_line))
        return raw[:, :4 * n].reshape(n, n, 4)[..., [2, 1, 0]]
""")

SCRIPT = READ_BACK + textwrap.dedent("""
    import sys
    from studio.x_image import open_x_image

    assert glfw.init()
    glfw.window_hint(glfw.VISIBLE, glfw.TRUE)
    window = glfw.create_window(200, 160, "x", None, None)
    assert window
    glfw.make_context_current(window)
    presenter = open_x_image(window)
    if presenter is None:
        print("NONE")
        sys.exit(0)
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)
    presenter.present(image, 10, 20)
    rgb = read_window(window, 10, 20, 64)
    image2 = image[::-1].copy()  # a second frame through the same buffer
    presenter.present(image2, 10, 20)
    rgb2 = read_window(window, 10, 20, 64)
    kind = type(presenter).__name__
    presenter.close()
    same = np.array_equal(rgb, image) and np.array_equal(rgb2, image2)
    print(("EQUAL " if same else "DIFFER %d " % int((rgb != image).sum())) + kind)
""")


APP_SCRIPT = READ_BACK + textwrap.dedent("""
    import sys, tempfile
    from pathlib import Path
    from studio.app import StudioApp
    from studio.bench import DEFAULT_MOTION, LIVE_PANEL, _playing, _prepare_project

    tmp = tempfile.TemporaryDirectory()  # removed when the script ends
    project = _prepare_project(Path(tmp.name), Path(sys.argv[1]), None)
    with StudioApp(project, size=(1280, 800), headless=False, deterministic=False,
                   motion_dir=DEFAULT_MOTION.parent) as app:
        assert app._x_image is not None
        shown = []  # the images put, and None for each full frame (GL draws the panel then)
        put, full = app._x_image.present, app.frame
        app._x_image.present = lambda image, x, y: (shown.append((image, x, y)), put(image, x, y))
        app.frame = lambda *a, **k: (shown.append(None), full(*a, **k))[1]
        app.state.select_panel(LIVE_PANEL)
        app.state.motion_file = str(DEFAULT_MOTION)
        app.state.playing = True
        puts = lambda: sum(s is not None for s in shown)
        for _ in range(60):
            app.run(seconds=0.5)
            if _playing(app) and puts() >= 5 and shown[-1] is not None:  # the window's last picture was put
                break
        assert puts() >= 5, f"{puts()} images put, {app.light_frame_count} light frames"
        assert shown[-1] is not None, "every run ended on a full frame"
        image, x, y = shown[-1]
        rect = app._ui_cache.rect
        assert (x, y) == (round(rect.x), round(rect.y)) and image.shape[0] == rect.render_side
        rgb = read_window(app.window, x, y, image.shape[0])
        assert image.std() > 5.0
        print("EQUAL" if np.array_equal(rgb, image) else "DIFFER %d" % int((rgb != image).sum()))
""")


def _run_on_xvfb(depth: int, script: str = SCRIPT, args: tuple[str, ...] = (), size: str = "320x240",
                 env: dict | None = None) -> str:
    read, write = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", f"{size}x{depth}", "-nolisten", "tcp"],
                              pass_fds=[write], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    try:
        number = b""
        while not number.endswith(b"\n"):
            chunk = os.read(read, 16)
            if not chunk:
                pytest.skip("Xvfb did not start")
            number += chunk
        env = {**os.environ, **(env or {}), "DISPLAY": f":{int(number)}"}
        env.pop("WAYLAND_DISPLAY", None)
        env.pop("PYOPENGL_PLATFORM", None)
        out = subprocess.run([sys.executable, "-c", script, *args], env=env, capture_output=True, text=True,
                             timeout=180)
        assert out.returncode == 0, out.stderr[-2000:]
        return out.stdout.strip().splitlines()[-1]
    finally:
        os.close(read)
        server.terminate()
        server.wait(10)


def test_the_image_lands_in_the_window_pixel_for_pixel_through_shared_memory():
    assert _run_on_xvfb(24) == "EQUAL ShmXImagePresenter"  # Xvfb has MIT-SHM, and it is local


def test_the_image_lands_in_the_window_pixel_for_pixel_through_plain_requests():
    assert _run_on_xvfb(24, env={"MORF_XSHM": "0"}) == "EQUAL XImagePresenter"


def test_a_server_with_other_pixels_gets_no_presenter():
    assert _run_on_xvfb(16) == "NONE"


@pytest.mark.gl
def test_the_studio_plays_a_motion_through_it(tiny_avatar_dir):
    """The real frame loop on an X server: light frames put the live image where the panel drew it."""
    assert _run_on_xvfb(24, APP_SCRIPT, (str(tiny_avatar_dir),), size="1280x800") == "EQUAL"
