"""Warp field: the texture-space offset field of the frame being trained on, and its effect."""

from __future__ import annotations

from imgui_bundle import ImVec2, imgui

from studio.context import UiContext
from studio.state import AppState
from studio.widgets import GREY, empty_state, fit_size, tex_ref

CAPTIONS = {
    "warp": "texture-space offset field of this frame",
    "warp_effect": "neural texture sampled with and without the offsets",
    "render": "renderer output",
    "target": "captured frame",
}


def draw(state: AppState, ui: UiContext) -> None:
    snap = ui.snapshot
    images = snap.progress.images if snap.progress is not None else {}
    warp_names = [n for n in images if n.startswith("warp")]
    if not warp_names:
        empty_state("No warp field yet.",
                    "Train an avatar (Training panel, 4): each training snapshot shows the texture-space "
                    "offset field of the frame being trained on, and what it does to the render.")
        return
    frame = snap.progress.frame
    imgui.text(f"Training step {snap.progress.step}" + (f", frame {frame}" if frame is not None else ""))
    imgui.text_colored(GREY, "Preview from the newest training snapshot; it refreshes as training runs.")
    imgui.separator()
    names = warp_names + [n for n in ("render", "target") if n in images]
    avail = imgui.get_content_region_avail()
    cell_w = max((avail.x - 12 * len(names)) / len(names), 64)
    cell_h = max(avail.y - 60, 64)
    for k, name in enumerate(names):
        img = images[name]
        tex = ui.textures.preview(f"warp:{name}", img, snap.seq)
        w, h = fit_size(tex.width, tex.height, cell_w, cell_h)
        if k:
            imgui.same_line()
        imgui.begin_group()
        imgui.image(tex_ref(tex), ImVec2(w, h))
        imgui.push_text_wrap_pos(imgui.get_cursor_pos_x() + w)
        imgui.text_wrapped(f"{name}: {CAPTIONS.get(name, '')}" if name in CAPTIONS else name)
        imgui.pop_text_wrap_pos()
        imgui.end_group()
