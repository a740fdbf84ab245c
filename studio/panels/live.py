"""Live render: the exported avatar played by the int8 player, an orbit camera and a motion picker."""

from __future__ import annotations

import time
from pathlib import Path

import moderngl
from imgui_bundle import ImVec2, imgui

from studio.context import UiContext
from studio.player import as_rgb, list_motions, load_motion
from studio.state import AppState
from studio.widgets import GREY, RED, empty_state, tex_ref

SIDEBAR_W = 320
RENDER_MAX = 640  # side of the rendered image when the player does not say
ANNY_BONES = 104


def draw(state: AppState, ui: UiContext) -> None:
    avail = imgui.get_content_region_avail()
    imgui.begin_child("live_view", ImVec2(max(avail.x - SIDEBAR_W - 8, 64), avail.y))
    if ui.player is None:
        empty_state("No exported avatar yet.",
                    ui.player_note or "Train an avatar, then export it ('morf export PROJECT'): "
                    "the int8 player renders it here in real time.")
    else:
        _draw_render(state, ui)
    imgui.end_child()
    imgui.same_line()
    imgui.begin_child("live_side", ImVec2(SIDEBAR_W, avail.y))
    _draw_sidebar(state, ui)
    imgui.end_child()


def _draw_render(state: AppState, ui: UiContext) -> None:
    live = ui.live
    avail = imgui.get_content_region_avail()
    side = max(min(avail.x, avail.y - 24), 16)  # players render square images
    n = int(getattr(ui.player, "size", 0) or min(side, RENDER_MAX))
    w = h = n
    camera = state.orbit.camera(n, n)
    clip = live.get("clip")
    pose = None
    if clip is not None and len(clip):
        pose = clip[live.get("clip_frame", 0) % len(clip)]
        if state.playing:
            live["clip_frame"] = live.get("clip_frame", 0) + 1
    t0 = time.perf_counter()
    try:
        out = ui.player.render(pose, camera)
    except Exception as e:  # keep the app alive; the message says what broke
        imgui.text_colored(RED, f"the player failed: {type(e).__name__}: {e}")
        return
    dt = time.perf_counter() - t0
    live["render_ms"] = dt * 1000 if "render_ms" not in live else 0.9 * live["render_ms"] + 100 * dt
    now = time.perf_counter()
    if "last_t" in live:
        gap = now - live["last_t"]
        live["fps"] = 1.0 / gap if "fps" not in live else 0.9 * live["fps"] + 0.1 / max(gap, 1e-6)
    live["last_t"] = now
    tex = out if isinstance(out, moderngl.Texture) else ui.textures.preview("live", as_rgb(out), live.setdefault("n", 0))
    live["n"] = live.get("n", 0) + 1
    imgui.set_cursor_pos_x(imgui.get_cursor_pos_x() + max((avail.x - side) / 2, 0))
    origin = imgui.get_cursor_screen_pos()
    imgui.image(tex_ref(tex), ImVec2(side, side))
    if imgui.is_item_hovered():
        io = imgui.get_io()
        if imgui.is_mouse_dragging(imgui.MouseButton_.left):
            state.orbit.drag(io.mouse_delta.x, io.mouse_delta.y)
        if io.mouse_wheel:
            state.orbit.zoom(io.mouse_wheel)
    fps = live.get("fps")
    imgui.get_window_draw_list().add_text(ImVec2(origin.x + 8, origin.y + 6), imgui.get_color_u32(imgui.Col_.text),
                                          f"{fps:.1f} fps" if fps else "-- fps")
    imgui.text_colored(GREY, f"render {live['render_ms']:.1f} ms at {w} x {h}; drag to orbit, wheel to zoom")


def _draw_sidebar(state: AppState, ui: UiContext) -> None:
    live = ui.live
    imgui.text("Camera")
    o = state.orbit
    imgui.text_colored(GREY, f"yaw {o.yaw_deg:.0f} deg, pitch {o.pitch_deg:.0f} deg, {o.distance_m:.2f} m")
    if imgui.button("Reset camera"):
        state.orbit = type(o)()
    imgui.separator()
    imgui.text("Motion")
    imgui.set_next_item_width(-1)
    changed, state.motion_dir = imgui.input_text("##motion_dir", state.motion_dir)
    if changed or live.get("motion_dir") != state.motion_dir:
        live["motion_dir"] = state.motion_dir
        live["motions"] = list_motions(state.motion_dir) if state.motion_dir else []
    motions: list[Path] = live.get("motions", [])
    if not motions:
        imgui.text_colored(GREY, "no .bvh or .npz files in this folder")
        return
    base = Path(state.motion_dir).expanduser()
    if imgui.begin_list_box("##motions", ImVec2(-1, -60)):
        for p in motions:
            name = str(p.relative_to(base)) if p.is_relative_to(base) else p.name
            if imgui.selectable(name, state.motion_file == str(p))[0]:
                state.motion_file = str(p)
                live["clip"], live["clip_note"] = load_motion(p, int(getattr(ui.player, "num_bones", ANNY_BONES)))
                live["clip_frame"] = 0
        imgui.end_list_box()
    if live.get("clip_note"):
        imgui.text_colored(GREY, live["clip_note"])
    elif live.get("clip") is not None:
        imgui.text(f"{len(live['clip'])} frames (Space plays)")
