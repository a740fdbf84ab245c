"""Keys from the window to imgui (studio.input_events): a chord that one slow frame saw whole still
arrives as a chord, and no event is dropped."""

from __future__ import annotations

import pytest

from tests.conftest import require

imgui = require("imgui_bundle").imgui  # before glfw: glfw must load imgui-bundle's GLFW library
glfw = require("glfw")
from studio.input_events import KeyQueue, translated  # noqa: E402

K = imgui.Key


class RecordingIO:
    """Stands in for imgui's IO: records what the queue hands over."""

    def __init__(self, typing: bool = False):
        self.events = []
        self.want_text_input = typing  # a text field had the keyboard last frame

    def add_key_event(self, key, down):
        self.events.append((key, down))

    def add_input_character(self, c):
        self.events.append(("char", chr(c)))


def _chord(q: KeyQueue, key: int) -> None:
    """Ctrl down, key down, Ctrl up, key up: what xdotool's 'key ctrl+a' delivers in one poll."""
    q.key(glfw.KEY_LEFT_CONTROL, 0, glfw.PRESS)
    q.key(key, 0, glfw.PRESS)
    q.key(glfw.KEY_LEFT_CONTROL, 0, glfw.RELEASE)
    q.key(key, 0, glfw.RELEASE)


def test_a_modifier_released_in_the_frame_of_its_chord_waits_a_frame():
    q, io = KeyQueue(), RecordingIO()
    _chord(q, glfw.KEY_A)
    assert q.feed(io) == 2 and q.pending == 2
    assert io.events == [(K.mod_ctrl, True), (K.left_ctrl, True), (K.a, True)]
    io.events.clear()
    assert q.feed(io) == 2 and q.pending == 0
    assert io.events == [(K.mod_ctrl, False), (K.left_ctrl, False), (K.a, False)]


def test_plain_typing_and_shift_pass_in_one_frame_in_order():
    q, io = KeyQueue(), RecordingIO()
    for key, ch in ((glfw.KEY_A, "a"), (glfw.KEY_SLASH, "/")):
        q.key(key, 0, glfw.PRESS)
        q.char(ord(ch))
        q.key(key, 0, glfw.RELEASE)
    q.key(glfw.KEY_LEFT_SHIFT, 0, glfw.PRESS)
    q.key(glfw.KEY_B, 0, glfw.PRESS)
    q.char(ord("B"))
    q.key(glfw.KEY_LEFT_SHIFT, 0, glfw.RELEASE)  # Shift makes no shortcut: nothing waits
    assert q.feed(io) == 10 and q.pending == 0
    assert [e for e in io.events if e[0] == "char"] == [("char", "a"), ("char", "/"), ("char", "B")]
    assert io.events[-2:] == [(K.mod_shift, False), (K.left_shift, False)]


def test_repeats_are_left_to_imgui_and_focus_loss_forgets_held_modifiers():
    q, io = KeyQueue(), RecordingIO()
    q.key(glfw.KEY_LEFT_CONTROL, 0, glfw.PRESS)
    q.key(glfw.KEY_BACKSPACE, 0, glfw.REPEAT)
    q.feed(io)
    assert io.events == [(K.mod_ctrl, True), (K.left_ctrl, True)]
    q.focus_lost()
    io.events.clear()
    q.key(glfw.KEY_A, 0, glfw.PRESS)
    q.key(glfw.KEY_A, 0, glfw.RELEASE)
    q.key(glfw.KEY_LEFT_CONTROL, 0, glfw.RELEASE)
    assert q.feed(io) == 3  # no chord: Ctrl was forgotten with the focus


def test_in_a_text_field_typed_keys_pass_as_characters_alone_and_held_keys_still_come_up():
    q, io = KeyQueue(), RecordingIO(typing=True)
    q.key(glfw.KEY_D, 0, glfw.PRESS)  # pressed before the field had the keyboard
    q.feed(RecordingIO())
    for key, ch in ((glfw.KEY_A, "a"), (glfw.KEY_SLASH, "/"), (glfw.KEY_SPACE, " ")):
        q.key(key, 0, glfw.PRESS)
        q.char(ord(ch))
        q.key(key, 0, glfw.RELEASE)
    q.key(glfw.KEY_BACKSPACE, 0, glfw.PRESS)
    q.key(glfw.KEY_BACKSPACE, 0, glfw.RELEASE)
    q.key(glfw.KEY_D, 0, glfw.RELEASE)
    _chord(q, glfw.KEY_A)
    q.feed(io)
    q.feed(io)
    assert io.events == [("char", "a"), ("char", "/"), ("char", " "), (K.backspace, True), (K.backspace, False),
                         (K.d, False), (K.mod_ctrl, True), (K.left_ctrl, True), (K.a, True),
                         (K.mod_ctrl, False), (K.left_ctrl, False), (K.a, False)]


@pytest.mark.parametrize("key,name,expected", [(glfw.KEY_Q, "a", glfw.KEY_A), (glfw.KEY_A, "a", glfw.KEY_A),
                                               (glfw.KEY_SEMICOLON, "m", glfw.KEY_M), (glfw.KEY_F1, None, glfw.KEY_F1),
                                               (glfw.KEY_KP_1, "1", glfw.KEY_KP_1), (glfw.KEY_M, ",", glfw.KEY_COMMA)])
def test_keys_are_named_as_the_users_layout_labels_them(key, name, expected):
    assert translated(key, name) == expected  # AZERTY's A sits where QWERTY has Q: Ctrl+A is that key


@pytest.mark.gl
def test_ctrl_a_released_within_one_slow_frame_selects_the_field(make_app):
    """The failure seen in a real X window at 70-130 ms frames: Ctrl down in one frame, then A
    down, Ctrl up and A up in the next (imgui applied A and the Ctrl release together)."""
    app = make_app(None)
    app.settle()
    app.click_item("new_source")
    app.type_text("clip.mp4")
    app.click_item("new_folder")
    app.click_item("new_source")  # the field's second focus
    app.keys.key(glfw.KEY_LEFT_CONTROL, 0, glfw.PRESS)
    app.frame()
    app.keys.key(glfw.KEY_A, 0, glfw.PRESS)
    app.keys.key(glfw.KEY_LEFT_CONTROL, 0, glfw.RELEASE)
    app.keys.key(glfw.KEY_A, 0, glfw.RELEASE)
    app.frame()
    app.keys.key(glfw.KEY_BACKSPACE, 0, glfw.PRESS)
    app.keys.key(glfw.KEY_BACKSPACE, 0, glfw.RELEASE)
    for _ in range(4):
        app.frame()
    assert app.state.new_source == ""
    assert app.keys.pending == 0
