"""The studio's one full-window layout: title row, panel tabs, the chosen panel, status line, help."""

from __future__ import annotations

from imgui_bundle import ImVec2, imgui

from studio.context import UiContext
from studio.panels import filtered, frames, help, live, start, status, training, warp
from studio.state import PANELS, AppState
from studio.widgets import GREY

PANEL_DRAW = (frames.draw, filtered.draw, warp.draw, training.draw, live.draw)
STATUS_H = 34

_WINDOW_FLAGS = (imgui.WindowFlags_.no_decoration | imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_saved_settings
                 | imgui.WindowFlags_.no_bring_to_front_on_focus)


def draw_ui(state: AppState, ui: UiContext) -> None:
    vp = imgui.get_main_viewport()
    imgui.set_next_window_pos(vp.pos)
    imgui.set_next_window_size(vp.size)
    imgui.begin("MoRF Studio##main", None, _WINDOW_FLAGS)
    if ui.view is None:
        imgui.begin_child("start", ImVec2(0, -STATUS_H))
        start.draw(state, ui)
        imgui.end_child()
    else:
        _title_row(state, ui)
        _tabs(state)
        imgui.begin_child("panel", ImVec2(0, -STATUS_H))
        PANEL_DRAW[state.panel](state, ui)
        imgui.end_child()
    status.draw(state, ui)
    imgui.end()
    help.draw(state, ui)


def _title_row(state: AppState, ui: UiContext) -> None:
    view = ui.view
    imgui.text(view.name)
    if imgui.is_item_hovered():
        imgui.set_tooltip(str(view.root))
    imgui.same_line()
    w, h = view.project.image_size
    fps = f", {view.project.fps:g} fps" if view.project.fps else ""
    imgui.text_colored(GREY, f"{view.num_frames} frames of {w} x {h}{fps}")


def _tabs(state: AppState) -> None:
    if not imgui.begin_tab_bar("panels"):
        return
    request, state.panel_request = state.panel_request, None
    for k, name in enumerate(PANELS):
        flags = imgui.TabItemFlags_.set_selected if request == k else 0
        selected, _ = imgui.begin_tab_item(f"{k + 1}  {name}", None, flags)
        if selected:
            if request is None or request == k:
                state.panel = k
            imgui.end_tab_item()
    imgui.end_tab_bar()
