"""The live render panel's motion browser in the headless studio: what it lists (golden
screenshots), and a typed path with synthetic key events that never stalls a frame."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from screenshots import check_golden
from tests.conftest import require
from test_motion_scan import write_motion_folder

pytestmark = pytest.mark.gl

imgui = require("imgui_bundle").imgui

K = imgui.Key
FRAME_DEADLINE_S = 0.5  # no UI frame may take longer, whatever the typed path (a frame is ~20 ms here)


def _timed(app, frames: list[float]) -> None:
    t = time.perf_counter()
    app.frame()
    frames.append(time.perf_counter() - t)


def _type(app, text: str, frames: list[float]) -> None:
    """Type ``text`` one character a frame, as a user does."""
    for ch in text:
        imgui.get_io().add_input_characters_utf8(ch)
        _timed(app, frames)


def _key(app, key, frames: list[float], ctrl: bool = False) -> None:
    io = imgui.get_io()
    if ctrl:
        io.add_key_event(K.mod_ctrl, True)
        io.add_key_event(K.left_ctrl, True)
    io.add_key_event(key, True)
    _timed(app, frames)
    io.add_key_event(key, False)
    if ctrl:
        io.add_key_event(K.left_ctrl, False)
        io.add_key_event(K.mod_ctrl, False)
    _timed(app, frames)


def _field(app) -> str:
    s = app.state
    return s.motion_dir if s.motion_dir_field is None else s.motion_dir_field


def test_motion_browser_lists_motions_greys_the_rest_and_leaves_out_a_project(make_app, tiny_project, tmp_path):
    write_motion_folder(tmp_path / "library")
    app = make_app("capture", motion_dir="library")
    app.settle()
    app.press(K._5)
    app.settle()
    names = {e.name for e in app.motions.latest().entries}
    assert "turn.npz" in names and not any(n.startswith(("capture/", "exported/")) for n in names)
    check_golden("studio_motion_browser", app.frame(capture=True))
    app.click_item("motion:weights.npz")  # greyed: not a motion, nothing happens
    assert app.state.motion_file is None
    app.click_item("motion:walk.bvh")
    assert Path(app.state.motion_file).resolve() == tmp_path / "library" / "walk.bvh"


def test_typing_a_path_lists_nothing_until_enter_and_never_stalls_a_frame(make_app, tiny_project, tmp_path):
    write_motion_folder(tmp_path / "library")
    app = make_app("capture")
    app.settle()
    app.press(K._5)
    app.settle()
    frames: list[float] = []
    app.click_item("motion_dir")
    _key(app, K.a, frames, ctrl=True)  # select all, as in any text field
    _key(app, K.backspace, frames)
    assert _field(app) == ""
    assert app.state.panel == 4  # keys went to the field, not to the panel bindings
    _type(app, "/", frames)  # once walked the whole file system on the UI thread
    assert app.motions.latest().folder == "motions" and app.motions.scanning is None  # not listed per keystroke
    check_golden("studio_motion_typed", app.frame(capture=True))  # "Enter lists this folder"
    _key(app, K.enter, frames)
    assert app.state.motion_dir == "/"
    while app.motions.scanning is not None:  # listing "/" (bounded) on its own thread; frames go on
        _timed(app, frames)
        time.sleep(0.005)
    assert app.motions.latest().folder == "/" and app.motions.latest().error is None
    assert "PermissionError" not in app.state.note and "display error" not in app.state.note
    # Ctrl+Backspace deletes a word; paste inserts the clipboard
    app.click_item("motion_dir")
    _key(app, K.a, frames, ctrl=True)
    _type(app, "library/dance", frames)
    _key(app, K.backspace, frames, ctrl=True)
    assert _field(app) in ("library/", "library")
    _key(app, K.a, frames, ctrl=True)
    imgui.set_clipboard_text("library")
    _key(app, K.v, frames, ctrl=True)
    assert _field(app) == "library"
    _key(app, K.enter, frames)
    while app.motions.scanning is not None:
        _timed(app, frames)
        time.sleep(0.005)
    app.settle()
    assert {e.name for e in app.motions.latest().motions} == {"dance/amass_walk.npz", "turn.npz", "walk.bvh"}
    assert app.motions.recent[:2] == ["library", "/"]
    assert max(frames) < FRAME_DEADLINE_S, f"a frame took {max(frames):.2f} s"


def test_a_dropped_folder_is_listed_and_a_dropped_motion_is_chosen(make_app, tiny_project, tmp_path):
    write_motion_folder(tmp_path / "library")
    app = make_app("capture")
    app.settle()
    app.drop(["library"])
    app.settle()
    assert app.state.panel == 4 and app.state.motion_dir == "library"
    assert "walk.bvh" in {e.name for e in app.motions.latest().motions}
    app.drop([str(tmp_path / "library" / "turn.npz")])
    app.frame()
    assert app.state.motion_file == str(tmp_path / "library" / "turn.npz")
