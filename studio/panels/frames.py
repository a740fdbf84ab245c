"""Frames: the current frame large, with keypoint / mask / fitted-body overlays, and a thumbnail strip."""

from __future__ import annotations

import numpy as np
from imgui_bundle import ImVec2, imgui, implot

from studio.context import UiContext
from studio.state import AppState
from studio.widgets import (GREEN, GREY, ORANGE, RED, col32, draw_skeleton, empty_state, fit_size, frame_buttons,
                             image_fitted, tex_ref)

THUMB_H = 72
STRIP_H = THUMB_H + 52  # thumbnails, their numbers and the horizontal scrollbar
SIDEBAR_W = 300


def draw(state: AppState, ui: UiContext) -> None:
    view = ui.view
    if view is None or view.num_frames == 0:
        empty_state("This project has no frames.")
        return
    avail = imgui.get_content_region_avail()
    view_h = max(avail.y - STRIP_H - 8, 50)
    imgui.begin_child("frame_view", ImVec2(max(avail.x - SIDEBAR_W - 8, 50), view_h))
    _draw_large(state, ui)
    imgui.end_child()
    imgui.same_line()
    imgui.begin_child("frame_info", ImVec2(SIDEBAR_W, view_h))
    _draw_sidebar(state, ui)
    imgui.end_child()
    _draw_strip(state, ui)


def _draw_large(state: AppState, ui: UiContext) -> None:
    i = state.frame
    tex = ui.textures.get(("frame", i))
    if state.show_fit and ui.view.has_fit_overlays():
        # the fit's overlay is the frame with the fitted body drawn in: show it instead
        tex = ui.textures.get(("fit", i)) or tex
    avail = imgui.get_content_region_avail()
    if tex is None:
        key_known = ui.textures.known(("frame", i))
        imgui.text_colored(RED if key_known else GREY, f"frame {i}: cannot read {ui.view.project.frame_path(i).name}"
                           if key_known else f"loading frame {i} ...")
        return
    w, _ = fit_size(tex.width, tex.height, avail.x, avail.y)
    imgui.set_cursor_pos_x(imgui.get_cursor_pos_x() + max((avail.x - w) / 2, 0))  # centred
    origin, scale = image_fitted(tex, avail.x, avail.y)
    p_max = ImVec2(origin.x + tex.width * scale, origin.y + tex.height * scale)
    dl = imgui.get_window_draw_list()
    if state.show_mask:
        mask = ui.textures.get(("mask", i))
        if mask is not None:
            dl.add_image(tex_ref(mask), origin, p_max)
    if state.show_keypoints:
        pts = ui.view.keypoints_of(i)
        if pts is not None:
            # keypoints are in capture pixels; the texture may be a scaled copy of the frame
            draw_skeleton(dl, origin, scale * tex.width / ui.view.project.image_size[0], pts)
    d = ui.view.decisions[i]
    if not d.used:
        dl.add_rect(origin, p_max, col32(1.0, 0.35, 0.3), 0.0, 3.0)


def _draw_sidebar(state: AppState, ui: UiContext) -> None:
    view, i = ui.view, state.frame
    imgui.text(f"Frame {i}")
    imgui.same_line()
    imgui.text_colored(GREY, f"(0 - {view.num_frames - 1})")
    imgui.separator()
    d = view.decisions[i]
    if d.used:
        imgui.text_colored(GREEN, "used for training")
    else:
        imgui.text_colored(RED if d.reason == "dropped by user" else ORANGE, "not used:")
        imgui.text_wrapped(d.reason or "")
    kp = view.keypoints_of(i)
    if view.keypoints is None:
        imgui.text_colored(GREY, "no keypoints file")
    elif kp is None:
        imgui.text_colored(GREY, "no person detected")
    else:
        imgui.text(f"keypoints: {int((kp[:, 2] >= 0.3).sum())} of {kp.shape[0]} confident")
    if view.residuals:
        r = view.residuals.get(i)
        imgui.text(f"fit residual: {r:.1f} px" if r is not None else "fit residual: --")
    imgui.separator()
    imgui.text("Overlays")
    _, state.show_keypoints = imgui.checkbox("keypoints (O)", state.show_keypoints)
    _, state.show_mask = imgui.checkbox("person mask (M)", state.show_mask)
    if view.has_fit_overlays():
        _, state.show_fit = imgui.checkbox("fitted body (F)", state.show_fit)
    else:
        imgui.text_colored(GREY, "fitted body: no fit yet")
    imgui.separator()
    frame_buttons(ui)
    imgui.same_line()
    if imgui.button("Pause (Space)" if state.playing else "Play (Space)"):
        ui.actions["play_pause"]()
    if view.residuals:
        _draw_residual_chart(state, ui)


def _draw_residual_chart(state: AppState, ui: UiContext) -> None:
    frames = np.array(sorted(ui.view.residuals), dtype=np.float64)
    values = np.array([ui.view.residuals[int(f)] for f in frames], dtype=np.float64)
    avail = imgui.get_content_region_avail()
    if implot.begin_plot("fit residual (px)", ImVec2(-1, max(min(avail.y, 200), 120)), implot.Flags_.no_legend):
        implot.setup_axes("frame", "px")
        implot.plot_bars("residual", frames, values, 0.67)
        implot.plot_inf_lines("current", np.array([float(state.frame)]))
        implot.end_plot()


def _draw_strip(state: AppState, ui: UiContext) -> None:
    view = ui.view
    imgui.begin_child("strip", ImVec2(0, STRIP_H), imgui.ChildFlags_.borders,
                      imgui.WindowFlags_.horizontal_scrollbar)
    w, h = view.project.image_size
    thumb_w = max(8.0, THUMB_H * w / max(h, 1))
    step = thumb_w + 6
    scroll, width = imgui.get_scroll_x(), imgui.get_window_width()
    if state.scroll_strip:  # centre the current frame (after a key press or a jump)
        scroll = max(0.0, state.frame * step - (width - thumb_w) / 2)
        imgui.set_scroll_x(scroll)
        state.scroll_strip = False
    first = max(0, int(scroll // step) - 1)
    last = min(view.num_frames, int((scroll + width) // step) + 2)
    dl = imgui.get_window_draw_list()
    top = imgui.get_cursor_pos_y()
    for i in range(first, last):  # only the visible thumbnails are laid out (long videos)
        imgui.set_cursor_pos(ImVec2(4 + i * step, top))
        p0 = imgui.get_cursor_screen_pos()
        tex = ui.textures.get(("thumb", i))
        if tex is not None:
            imgui.image(tex_ref(tex), ImVec2(thumb_w, THUMB_H))
        else:
            imgui.dummy(ImVec2(thumb_w, THUMB_H))
            dl.add_rect_filled(p0, ImVec2(p0.x + thumb_w, p0.y + THUMB_H), col32(0.2, 0.2, 0.22))
        if imgui.is_item_clicked():
            state.frame = i
        d = view.decisions[i]
        p1 = ImVec2(p0.x + thumb_w, p0.y + THUMB_H)
        if not d.used:
            color = col32(1.0, 0.35, 0.3) if d.reason == "dropped by user" else col32(1.0, 0.68, 0.25)
            dl.add_rect(p0, p1, color, 0.0, 2.0)
            dl.add_line(p0, p1, color, 2.0)
        if i == state.frame:
            dl.add_rect(ImVec2(p0.x - 3, p0.y - 3), ImVec2(p1.x + 3, p1.y + 3), col32(1, 1, 1), 0.0, 2.0)
        dl.add_text(ImVec2(p0.x + 3, p1.y + 2), col32(0.8, 0.8, 0.8), str(i))
    imgui.set_cursor_pos(ImVec2(4 + view.num_frames * step, top))
    imgui.dummy(ImVec2(1, THUMB_H + 18))
    imgui.end_child()
