"""Filtered frames: every frame not used for training, why, and by whose decision."""

from __future__ import annotations

from imgui_bundle import ImVec2, imgui

from studio.commands import RestoreFrame
from studio.context import UiContext
from studio.state import AppState
from studio.widgets import GREEN, GREY, ORANGE, RED, empty_state, frame_buttons, tex_ref

ROW_THUMB_H = 40


def draw(state: AppState, ui: UiContext) -> None:
    view = ui.view
    if view is None:
        empty_state("No project is open.")
        return
    unused = [d for d in view.decisions if not d.used]
    by_user = sum(1 for d in unused if d.reason == "dropped by user")
    d = view.decisions[state.frame]
    imgui.text(f"Current frame {state.frame}:")
    imgui.same_line()
    if d.used:
        imgui.text_colored(GREEN, "used")
    else:
        imgui.text_colored(RED if d.reason == "dropped by user" else ORANGE, f"not used ({d.reason})")
    imgui.same_line()
    frame_buttons(ui)
    imgui.text_colored(GREY, f"{len(unused)} of {view.num_frames} frames are not used: {by_user} dropped by you, "
                             f"{len(unused) - by_user} by the automatic filter. N jumps to the next one.")
    imgui.separator()
    if not unused:
        empty_state("Every frame is used for training.",
                    "Frames the automatic filter rejects (after fitting) and frames you drop (D) are listed here.")
        return
    flags = imgui.TableFlags_.row_bg | imgui.TableFlags_.borders_inner_h | imgui.TableFlags_.scroll_y
    if not imgui.begin_table("unused", 4, flags, ImVec2(0, 0)):
        return
    imgui.table_setup_column("Frame", imgui.TableColumnFlags_.width_fixed, 140)
    imgui.table_setup_column("Reason", imgui.TableColumnFlags_.width_stretch)
    imgui.table_setup_column("Decided by", imgui.TableColumnFlags_.width_fixed, 150)
    imgui.table_setup_column("", imgui.TableColumnFlags_.width_fixed, 130)
    imgui.table_setup_scroll_freeze(0, 1)
    imgui.table_headers_row()
    w, h = view.project.image_size
    for d in unused:
        i = d.index
        imgui.push_id(i)
        imgui.table_next_row(0, ROW_THUMB_H + 4)
        imgui.table_next_column()
        tex = ui.textures.get(("thumb", i))
        if tex is not None:
            imgui.image(tex_ref(tex), ImVec2(ROW_THUMB_H * w / max(h, 1), ROW_THUMB_H))
        else:
            imgui.dummy(ImVec2(ROW_THUMB_H * w / max(h, 1), ROW_THUMB_H))
        imgui.same_line()
        if imgui.selectable(f"{i}", i == state.frame)[0]:
            state.frame = i
            state.scroll_strip = True
        imgui.table_next_column()
        imgui.text_wrapped(d.reason or "")
        imgui.table_next_column()
        user = d.reason == "dropped by user"
        imgui.text_colored(RED if user else ORANGE, "you" if user else "automatic filter")
        imgui.table_next_column()
        if imgui.button("Restore" if user else "Use anyway"):
            ui.send(RestoreFrame(i))
        imgui.pop_id()
    imgui.end_table()
