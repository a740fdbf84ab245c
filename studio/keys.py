"""Keyboard bindings: one table drives both the handler and the help overlay."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from imgui_bundle import imgui

K = imgui.Key


@dataclass(frozen=True)
class Binding:
    keys: tuple[imgui.Key, ...]
    label: str  # how the help overlay writes the keys
    action: str  # name of the action the app runs
    help: str  # what it does, in words
    repeat: bool = False  # held key repeats (frame stepping)


BINDINGS = (
    Binding((K.right_arrow, K.j), "Right / J", "next_frame", "next frame", repeat=True),
    Binding((K.left_arrow, K.k), "Left / K", "prev_frame", "previous frame", repeat=True),
    Binding((K.n,), "N", "next_flagged", "jump to the next flagged (unused) frame"),
    Binding((K.d, K.delete), "D / Delete", "drop_frame", "drop the current frame from training"),
    Binding((K.r, K.backspace), "R / Backspace", "restore_frame", "use the current frame again (undo a drop, or overrule the filter)"),
    Binding((K.space,), "Space", "play_pause", "play / pause the frames"),
    Binding((K.o,), "O", "toggle_keypoints", "show / hide keypoints"),
    Binding((K.m,), "M", "toggle_mask", "show / hide the person mask"),
    Binding((K.f,), "F", "toggle_fit", "show / hide the fitted body"),
    Binding((K._1,), "1", "panel_0", "Frames panel"),
    Binding((K._2,), "2", "panel_1", "Filtered frames panel"),
    Binding((K._3,), "3", "panel_2", "Warp field panel"),
    Binding((K._4,), "4", "panel_3", "Training panel"),
    Binding((K._5,), "5", "panel_4", "Live render panel"),
    Binding((K.tab,), "Tab", "next_panel", "next panel"),
    Binding((K.h, K.f1), "H / F1", "toggle_help", "show / hide this help"),
    Binding((K.escape,), "Esc", "close_help", "close this help"),
)


def handle_keys(actions: dict[str, Callable[[], None]]) -> list[str]:
    """Run the action of every binding pressed this frame; returns the action names run.

    Keys are ignored while a text field has the keyboard (typing a path must not drop frames).
    """
    if imgui.get_io().want_text_input:
        return []
    ran = []
    for b in BINDINGS:
        if any(imgui.is_key_pressed(k, b.repeat) for k in b.keys):
            fn = actions.get(b.action)
            if fn is not None:
                fn()
                ran.append(b.action)
    return ran
