"""Live render: the exported avatar played by the int8 player, an orbit camera and a motion picker.

The player runs on its own thread (``studio.live_render``): this panel only posts the pose and
camera it wants and shows the newest finished image, so a slow render lowers the render fps,
never the UI's.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Callable

import moderngl
from imgui_bundle import ImVec2, imgui

from studio.context import UiContext
from studio.live_render import LiveRenderer, LiveRequest
from studio.player import load_live_motion_async
from studio.state import AppState, ImageRect, LivePanelState
from studio.widgets import GREY, RED, empty_state, remember_item, tex_ref

MOTION_FIELD = "##motion_dir"

SIDEBAR_W = 320
ANNY_BONES = 104
RENDER_MAX = 640  # side of the rendered image when the player does not say


def draw(state: AppState, ui: UiContext) -> None:
    _sync_motion(state, ui)
    avail = imgui.get_content_region_avail()
    imgui.begin_child("live_view", ImVec2(max(avail.x - SIDEBAR_W - 8, 64), avail.y))
    lr = ui.live_render
    if lr is None:
        empty_state("No exported avatar yet.",
                    ui.player_note or "Train an avatar, then export it (Training panel, or 'morf export "
                    "PROJECT'): the int8 player renders it here in real time.")
    elif not lr.ready:
        if lr.note:
            empty_state("The exported avatar cannot be played.", lr.note)
        else:
            imgui.text_colored(GREY, "opening the exported avatar ...")
    else:
        _draw_render(state, ui)
    imgui.end_child()
    imgui.same_line()
    imgui.begin_child("live_side", ImVec2(SIDEBAR_W, avail.y))
    _draw_sidebar(state, ui)
    imgui.end_child()


def _sync_motion(state: AppState, ui: UiContext) -> None:
    """Load the chosen motion in the background (retargeting a BVH takes seconds) and pick it up."""
    live = ui.live
    if live.clip_path != state.motion_file:
        live.clip_path = state.motion_file
        state.motion_time = 0.0
        live.clip, live.clip_note, live.clip_loading = None, None, None
        if state.motion_file is not None:
            bones = (ui.live_render.num_bones if ui.live_render is not None else 0) or ANNY_BONES
            live.clip_loading = load_live_motion_async(Path(state.motion_file), bones)
            live.clip_loading.add_done_callback(lambda _: ui.redraw_within(0.0))  # show it as soon as it loads
    loading = live.clip_loading
    if loading is not None and loading.done():
        live.clip, live.clip_note = loading.result()
        if live.clip is not None and len(live.clip):
            live.clip_centre = live.clip.transl.mean(axis=0)
        live.clip_loading = None


def _request(state: AppState, ui: UiContext, side: int) -> int | None:
    """Post this frame's pose and camera to the render thread; returns the motion frame shown."""
    return post_request(state, ui.live, ui.live_render, ui.redraw_within, side, imgui.get_io().delta_time)


def post_request(state: AppState, live: LivePanelState, lr: LiveRenderer, redraw_within: Callable[[float], None],
                 side: int, dt: float) -> int | None:
    """Advance the motion by ``dt`` seconds while playing and ask ``lr`` for that frame at ``side``
    pixels; returns the motion frame index (None: rest pose). Needs no imgui frame: the app's light
    frames call it too (:mod:`studio.ui_cache`)."""
    clip = live.clip
    pose, index = None, None
    if clip is not None and len(clip):
        if state.playing:
            state.motion_time += dt
        index = int(state.motion_time * clip.fps) % len(clip)
        pose = (clip.rotvecs[index], clip.transl[index])  # the player takes numpy; clip[index] is a torch BodyPose
    o = state.orbit
    if clip is not None and len(clip):
        # orbit around the person, following the root over the ground (a walk stays in view) at the
        # clip's mean height (no bobbing)
        root = clip.transl[index]
        follow = (root[0], root[1], live.clip_centre[2])
        o = dataclasses.replace(o, target=tuple(float(a + b) for a, b in zip(o.target, follow)))
    camera = o.camera(side, side)
    key = (state.motion_file if pose is not None else None, index, o.yaw_deg, o.pitch_deg, o.distance_m,
           tuple(o.target), o.fov_y_deg, side)
    posted = lr.request(LiveRequest(pose, camera, key))
    if state.playing and clip is not None and len(clip) and (not posted or lr.pipelined):
        # the next motion frame is due at the clip's rate. A serial render thread wakes the UI with
        # the frame it finishes, which is when it can take a new pose; a pipelined one takes the
        # next pose while this one shades, so the UI asks for it on the clip's clock.
        redraw_within((math.floor(state.motion_time * clip.fps) + 1) / clip.fps - state.motion_time)
    return index


def _draw_render(state: AppState, ui: UiContext) -> None:
    lr = ui.live_render
    avail = imgui.get_content_region_avail()
    side = max(min(avail.x, avail.y - 48), 16)  # players render square images
    n = lr.size or int(min(side, RENDER_MAX))  # players with no fixed size render at the view's size
    index = _request(state, ui, n)
    frame = lr.latest()
    # Shown pixel for pixel where the panel has room (what the player rendered, not a resampling of
    # it, and the cheapest draw in software GL), scaled down where it has not.
    exact = side >= n
    side = float(n) if exact else side
    imgui.set_cursor_pos_x(imgui.get_cursor_pos_x() + max((avail.x - side) / 2, 0))
    if exact:  # on whole pixels: each texel lands on one
        pos = imgui.get_cursor_screen_pos()
        imgui.set_cursor_screen_pos(ImVec2(math.floor(pos.x), math.floor(pos.y)))
    origin = imgui.get_cursor_screen_pos()
    if frame is None:
        imgui.dummy(ImVec2(side, side))
    else:
        tex = ui.textures.preview("live", frame.image, frame.seq, ring=3)
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST) if exact else (moderngl.LINEAR, moderngl.LINEAR)
        imgui.image(tex_ref(tex), ImVec2(side, side))
        dl = imgui.get_window_draw_list()
        lo, hi = dl.get_clip_rect_min(), dl.get_clip_rect_max()
        if lo.x <= origin.x and lo.y <= origin.y and origin.x + side <= hi.x and origin.y + side <= hi.y:
            ui.live.image_rect = ImageRect(origin.x, origin.y, side, n)  # whole on screen: light frames may redraw it
    if imgui.is_item_hovered():
        io = imgui.get_io()
        if imgui.is_mouse_dragging(imgui.MouseButton_.left):
            state.orbit.drag(io.mouse_delta.x, io.mouse_delta.y)
        if io.mouse_wheel:
            state.orbit.zoom(io.mouse_wheel)
    ui_fps = 1000.0 / ui.frame_ms if ui.frame_ms > 0 else 0.0
    if frame is None:
        imgui.text_colored(GREY, "rendering the first frame ...")
    else:
        # below the image, not on it: light frames redraw the image alone
        render_fps = f"{frame.fps:.1f} fps, " if frame.fps else ""
        imgui.text_colored(GREY, f"render {render_fps}{frame.render_ms:.1f} ms at {n} x {n} (own thread); "
                                 f"UI {ui.frame_ms:.1f} ms a frame ({min(ui_fps, 999):.0f} fps possible)")
    shown = f"motion frame {index}" if index is not None else "rest pose"
    imgui.text_colored(GREY, f"{shown}; drag to orbit, wheel to zoom, Space plays")
    if lr.note:
        imgui.text_colored(RED, lr.note)


def _draw_sidebar(state: AppState, ui: UiContext) -> None:
    live = ui.live
    imgui.text("Camera")
    o = state.orbit
    imgui.text_colored(GREY, f"yaw {o.yaw_deg:.0f} deg, pitch {o.pitch_deg:.0f} deg, {o.distance_m:.2f} m")
    if imgui.button("Reset camera"):
        state.orbit = type(o)()
    imgui.separator()
    imgui.text("Motion")
    _draw_motion_browser(state, ui)
    if live.clip_loading is not None:
        imgui.text_colored(GREY, f"loading {Path(state.motion_file).name} ...")
    elif live.clip_note:
        imgui.text_colored(GREY, live.clip_note)
    elif live.clip is not None:
        imgui.text(f"{Path(state.motion_file).name}: {len(live.clip)} frames at {live.clip.fps:g} fps")


def commit_motion_dir(state: AppState, ui: UiContext, folder: str) -> None:
    """List ``folder`` (on the browser's thread): the path was committed, not just typed."""
    state.motion_dir, state.motion_dir_field = folder, None
    if ui.motions is not None:
        ui.motions.commit(folder)


def _draw_motion_browser(state: AppState, ui: UiContext) -> None:
    """The folder field (listed on Enter, never per keystroke), recent folders, and the listing:
    motions to pick, files that are no motions greyed with the reason."""
    browser = ui.motions
    text = state.motion_dir if state.motion_dir_field is None else state.motion_dir_field
    imgui.set_next_item_width(-1 - (70 if browser is not None and browser.recent else 0))
    entered, text = imgui.input_text(MOTION_FIELD, text, imgui.InputTextFlags_.enter_returns_true)
    remember_item(state.item_rects, "motion_dir")
    if entered:
        commit_motion_dir(state, ui, text.strip())
    else:
        state.motion_dir_field = text if text != state.motion_dir else None
    if browser is None:
        return
    if browser.recent:
        imgui.same_line()
        if imgui.button("Recent", ImVec2(62, 0)):
            imgui.open_popup("recent_motion_dirs")
        remember_item(state.item_rects, "motion_dir:recent")
        if imgui.begin_popup("recent_motion_dirs"):
            for i, folder in enumerate(list(browser.recent)):
                if imgui.selectable(folder, folder == state.motion_dir)[0]:
                    commit_motion_dir(state, ui, folder)
                remember_item(state.item_rects, f"motion_dir:recent:{i}")
            imgui.end_popup()
    if state.motion_dir_field is not None:
        imgui.text_colored(GREY, "Enter lists this folder")
    scan = browser.latest()
    if browser.scanning is not None:
        imgui.text_colored(GREY, f"listing {browser.scanning} ...")
        return
    if scan is None:
        return
    if scan.error:
        imgui.push_text_wrap_pos(0.0)
        imgui.text_colored(GREY, scan.error)
        imgui.pop_text_wrap_pos()
        return
    if not scan.motions:
        imgui.text_colored(GREY, f"no .bvh or .npz motions in {scan.folder}")
    if scan.entries and imgui.begin_list_box("##motions", ImVec2(-1, -60 - 36 * len(scan.notes))):
        for e in scan.entries:
            if e.is_motion:
                if imgui.selectable(e.name, state.motion_file == str(e.path))[0]:
                    state.motion_file = str(e.path)
            else:
                imgui.begin_disabled()
                imgui.selectable(f"{e.name}: {e.reason}", False)
                imgui.end_disabled()
                if imgui.is_item_hovered(imgui.HoveredFlags_.allow_when_disabled):
                    imgui.set_tooltip(f"{e.name} cannot be played: {e.reason}")
            remember_item(state.item_rects, f"motion:{e.name}")
        imgui.end_list_box()
    imgui.push_text_wrap_pos(0.0)
    for note in scan.notes:
        imgui.text_colored(GREY, note)
    imgui.pop_text_wrap_pos()
