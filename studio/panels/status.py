"""Status line: what the worker is doing, and any error, in words."""

from __future__ import annotations

from imgui_bundle import imgui

from studio.context import UiContext
from studio.snapshot import STATE_WORDS
from studio.state import AppState
from studio.widgets import GREY, RED, hms


def describe(ui: UiContext) -> str:
    """One sentence about the worker."""
    s = ui.snapshot
    if s.stage is None:
        return "Ready." if ui.view is not None else "No project open."
    step = f" ({s.chain_step[0]} of {s.chain_step[1]})" if s.chain_step else ""
    text = f"{s.stage.capitalize()}{step}: {STATE_WORDS.get(s.state, s.state)}"
    p = s.progress
    if p is not None:
        text += f", step {p.step}" + (f" of {p.total}" if p.total else "")
        if p.message:
            text += f" ({p.message})"
    if s.busy and s.eta_s is not None:
        text += f", {hms(s.eta_s)} left"
    return text + "."


def draw(state: AppState, ui: UiContext) -> None:
    imgui.separator()
    imgui.text(describe(ui))
    s = ui.snapshot
    note = state.note or s.message
    if note:
        imgui.same_line(spacing=24)
        imgui.text_colored(GREY, note)
    if s.error:
        imgui.same_line(spacing=24)
        imgui.text_colored(RED, f"Error: {s.error}")
    label = "H: help"
    imgui.same_line(max(imgui.get_window_width() - imgui.calc_text_size(label).x - 16, 0))
    imgui.text_colored(GREY, label)
