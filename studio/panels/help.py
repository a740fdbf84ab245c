"""Help overlay: every key, from the same table the key handler uses."""

from __future__ import annotations

from imgui_bundle import ImVec2, imgui

from studio.context import UiContext
from studio.keys import BINDINGS
from studio.state import AppState
from studio.widgets import GREY


def draw(state: AppState, ui: UiContext) -> None:
    if not state.show_help:
        return
    vp = imgui.get_main_viewport()
    imgui.set_next_window_pos(ImVec2(vp.pos.x + vp.size.x / 2, vp.pos.y + vp.size.y / 2), imgui.Cond_.always, ImVec2(0.5, 0.5))
    imgui.set_next_window_bg_alpha(0.96)
    flags = (imgui.WindowFlags_.always_auto_resize | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings
             | imgui.WindowFlags_.no_move)
    imgui.set_next_window_focus()
    opened, state.show_help = imgui.begin("Keys##help", state.show_help, flags)
    if opened:
        if imgui.begin_table("keys", 2, imgui.TableFlags_.row_bg | imgui.TableFlags_.sizing_fixed_fit):
            for b in BINDINGS:
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text(b.label)
                imgui.table_next_column()
                imgui.text(b.help)
            imgui.end_table()
        imgui.text_colored(GREY, "Mouse: click a thumbnail to open it; drag the live render to orbit, wheel to zoom.")
    imgui.end()
