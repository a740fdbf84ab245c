"""Small drawing helpers shared by the panels (image fitting, overlays, messages, the buttons
several panels show)."""

from __future__ import annotations

import moderngl
import numpy as np
from imgui_bundle import ImVec2, ImVec4, imgui

from morf.capture.keypoint_layout import KEYPOINT_NAMES, SKELETON
from studio.commands import Pause, Resume, Stop

GREY = ImVec4(0.62, 0.62, 0.66, 1.0)
RED = ImVec4(1.0, 0.42, 0.38, 1.0)
ORANGE = ImVec4(1.0, 0.68, 0.25, 1.0)
GREEN = ImVec4(0.45, 0.85, 0.45, 1.0)

_LEFT = {i for i, n in enumerate(KEYPOINT_NAMES) if n.startswith("left")}
_RIGHT = {i for i, n in enumerate(KEYPOINT_NAMES) if n.startswith("right")}
KP_MIN_CONFIDENCE = 0.3  # points below this are guesses; drawing them would mislead the review


def col32(r: float, g: float, b: float, a: float = 1.0) -> int:
    return imgui.get_color_u32(ImVec4(r, g, b, a))


def tex_ref(tex: moderngl.Texture) -> imgui.ImTextureRef:
    return imgui.ImTextureRef(tex.glo)


def fit_size(w: int, h: int, max_w: float, max_h: float) -> tuple[float, float]:
    """Largest (w, h) with the image's aspect ratio inside max_w x max_h."""
    s = max(min(max_w / max(w, 1), max_h / max(h, 1)), 0.01)
    return w * s, h * s


def empty_state(text: str, detail: str | None = None) -> None:
    """A centred, greyed message for a panel with nothing to show yet."""
    avail = imgui.get_content_region_avail()
    imgui.dummy(ImVec2(0, max(avail.y * 0.3, 0)))
    width = min(avail.x, 620)
    imgui.set_cursor_pos_x(imgui.get_cursor_pos_x() + max((avail.x - width) / 2, 0))
    imgui.push_text_wrap_pos(imgui.get_cursor_pos_x() + width)
    imgui.text_wrapped(text)
    if detail:
        imgui.spacing()
        imgui.text_colored(GREY, detail)
    imgui.pop_text_wrap_pos()


def draw_skeleton(dl: imgui.ImDrawList, origin: ImVec2, scale: float, points: np.ndarray) -> None:
    """Keypoint overlay: (23, 3) x, y (image pixels), confidence -> lines and dots on screen."""
    left, right, mid = col32(0.3, 0.75, 1.0), col32(1.0, 0.6, 0.2), col32(0.95, 0.95, 0.95)

    def at(k: int) -> ImVec2:
        return ImVec2(origin.x + points[k, 0] * scale, origin.y + points[k, 1] * scale)

    thick = max(1.5, 2.0 * min(scale, 2.0))
    for a, b in SKELETON:
        if points[a, 2] < KP_MIN_CONFIDENCE or points[b, 2] < KP_MIN_CONFIDENCE:
            continue
        c = left if (a in _LEFT and b in _LEFT) else right if (a in _RIGHT and b in _RIGHT) else mid
        dl.add_line(at(a), at(b), c, thick)
    for k in range(points.shape[0]):
        if points[k, 2] >= KP_MIN_CONFIDENCE:
            c = left if k in _LEFT else right if k in _RIGHT else mid
            dl.add_circle_filled(at(k), thick * 1.4, c)


def image_fitted(tex: moderngl.Texture, max_w: float, max_h: float) -> tuple[ImVec2, float]:
    """Draw ``tex`` as large as fits; returns (screen top-left, pixels per texel)."""
    w, h = fit_size(tex.width, tex.height, max_w, max_h)
    origin = imgui.get_cursor_screen_pos()
    imgui.image(tex_ref(tex), ImVec2(w, h))
    return origin, w / tex.width


def hms(seconds: float | None) -> str:
    """1:02:03 / 2:03 / '--' for an unknown duration."""
    if seconds is None or not np.isfinite(seconds):
        return "--"
    s = int(round(seconds))
    h, m, s = s // 3600, s // 60 % 60, s % 60
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def remember_item(rects: dict, name: str) -> None:
    """Store where the last drawn item is, (x0, y0, x1, y1) screen pixels, under ``name``.

    Scripted input (tests, screenshot scripts) clicks controls by name through these rectangles,
    so it does not break when a layout shifts by a few pixels.
    """
    lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    rects[name] = (lo.x, lo.y, hi.x, hi.y)


def run_buttons(ui) -> None:
    """Pause (Resume while paused) and Stop for the worker's running stage, on one line.

    The start screen's progress line and the training panel's stage row draw the same pair, so a
    stage is paused and stopped alike wherever it was started from. ``ui``: the frame's
    :class:`studio.context.UiContext` (its snapshot and its command queue).
    """
    if ui.snapshot.state == "paused":
        if imgui.button("Resume"):
            ui.send(Resume())
    elif imgui.button("Pause"):
        ui.send(Pause())
    imgui.same_line()
    if imgui.button("Stop"):
        ui.send(Stop())


def frame_buttons(ui) -> None:
    """Drop (D) and Restore (R) for the current frame, the same actions as the keys, in the
    frames panel and the filtered-frames panel alike."""
    if imgui.button("Drop (D)"):
        ui.actions["drop_frame"]()
    imgui.same_line()
    if imgui.button("Restore (R)"):
        ui.actions["restore_frame"]()
