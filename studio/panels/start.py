"""Start screen: open a capture project by path; shows why the last attempt failed."""

from __future__ import annotations

from imgui_bundle import ImVec2, imgui

from studio.context import UiContext
from studio.state import AppState
from studio.widgets import GREY, RED

WIDTH = 640


def draw(state: AppState, ui: UiContext) -> None:
    avail = imgui.get_content_region_avail()
    imgui.dummy(ImVec2(0, avail.y * 0.22))
    x0 = imgui.get_cursor_pos_x() + max((avail.x - WIDTH) / 2, 0)
    imgui.set_cursor_pos_x(x0)
    imgui.begin_group()
    imgui.text("MoRF Studio")
    imgui.text_colored(GREY, "Full-body neural avatars from a video of a person turning in place.")
    imgui.dummy(ImVec2(0, 12))
    imgui.text("Open a capture project folder:")
    imgui.set_next_item_width(WIDTH - 90)
    entered, state.open_path = imgui.input_text("##project_path", state.open_path,
                                                imgui.InputTextFlags_.enter_returns_true)
    imgui.same_line()
    if (imgui.button("Open", ImVec2(80, 0)) or entered) and state.open_path.strip():
        ui.open_project(state.open_path.strip())
    if state.project_error:
        imgui.dummy(ImVec2(0, 8))
        imgui.push_text_wrap_pos(x0 + WIDTH)
        imgui.text_colored(RED, f"Cannot open this project: {state.project_error}")
        imgui.pop_text_wrap_pos()
    imgui.dummy(ImVec2(0, 12))
    imgui.push_text_wrap_pos(x0 + WIDTH)
    imgui.text_colored(GREY, "Make a project from a video with 'morf run PROJECT --video FILE' (ingest, fit, train "
                             "and export), or a synthetic one with 'morf synth PROJECT'. Press H for the keys.")
    imgui.pop_text_wrap_pos()
    imgui.end_group()
