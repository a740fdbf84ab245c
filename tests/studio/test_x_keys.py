"""Text fields in a real X window, typed into by xdotool on a private Xvfb server: Ctrl+A on a
field's second focus, Ctrl+Backspace, typing, with frames made slow as on a busy machine."""

from __future__ import annotations

import shutil
import textwrap

import pytest

from test_x_image import _run_on_xvfb

pytestmark = [pytest.mark.gl, pytest.mark.slow,
              pytest.mark.skipif(shutil.which("Xvfb") is None or shutil.which("xdotool") is None,
                                 reason="needs Xvfb and xdotool (apt-get install xvfb xdotool)")]

# The app's own frame loop in a window; a thread drives xdotool. Each frame first sleeps 150 ms
# (a busy machine: 70-130 ms frames were seen), so one poll of the window gets A down and Ctrl up
# together, the case imgui's own GLFW callbacks lost.
SCRIPT = textwrap.dedent("""
    import subprocess, threading, time
    from studio.app import StudioApp

    slow = StudioApp.frame
    def frame(self, capture=False):
        time.sleep(0.15)
        return slow(self, capture)
    StudioApp.frame = frame
    app = StudioApp(None, size=(1280, 800), headless=False, deterministic=False, remember_folders=False)
    seen = []

    def xdo(*args):
        subprocess.run(["xdotool", *map(str, args)], check=True)
        time.sleep(0.35)

    def click(name):
        x0, y0, x1, y1 = app.state.item_rects[name]
        xdo("mousemove", "--window", wid, int((x0 + x1) / 2), int((y0 + y1) / 2))
        xdo("click", "1")

    def drive():
        global wid
        try:
            time.sleep(1.0)
            wid = subprocess.check_output(["xdotool", "search", "--name", "MoRF Studio"]).split()[0].decode()
            click("new_source")
            xdo("type", "--delay", "60", "/tmp/abc")
            xdo("key", "ctrl+BackSpace")
            seen.append(app.state.new_source)
            for _ in range(2):
                click("new_folder")
                click("new_source")  # the field's second (third) focus
                xdo("keydown", "ctrl")
                xdo("keydown", "a", "keyup", "ctrl", "keyup", "a")
                xdo("type", "x")
                seen.append(app.state.new_source)
        finally:
            app.request_close()

    thread = threading.Thread(target=drive)
    thread.start()
    app.run()
    thread.join()
    app.close()
    print("|".join(seen))
""")


def test_ctrl_a_on_a_fields_second_focus_selects_it_in_a_real_window():
    assert _run_on_xvfb(24, SCRIPT, size="1280x800").split("|") == ["/tmp/", "x", "x"]
