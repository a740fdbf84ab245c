"""The comparison sheet and the space-time (y-t) slice image of one target.

Comparison sheet: one row per chosen frame, one column per source (the real frames, each run,
the floor last), each column headed by its name and its mean person PSNR on the target. Every
cell is a square of ``cell`` pixels: the largest evaluation side among the columns, clamped to
[``CELL_MIN``, ``CELL_MAX``] (small renders are enlarged with nearest-neighbour sampling, so
their pixels stay visible). Size: ``columns * cell`` by ``LABEL_H + rows * cell``.

Y-t slices (MoRF Fig. 5): for a fixed image column through the person, that column of every
frame side by side (height = image rows, width = time), one panel per source, labelled like the
sheet. A render that flickers shows vertical streaks the real panel lacks. Each frame is
``max(1, ceil(SLICE_MIN_W / T))`` pixels wide, each panel at least ``PANEL_MIN_W`` wide, so the
image is ``sources * panel + (sources - 1) * GAP`` by ``LABEL_H + cell + CAPTION_H``.

Head crops: the head of each sheet row at native size (the square around the fitted head's box),
real | each run | floor, every crop enlarged to ``HEAD_CELL`` pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from morf.resources import FONT

CELL_MIN, CELL_MAX = 160, 384
LABEL_H = 40  # header band: two lines of text
CAPTION_H = 38  # caption band under the y-t panels: two lines
SLICE_MIN_W = 96  # narrowest time axis of a y-t panel
PANEL_MIN_W = 180  # narrowest y-t panel (room for its label)
GAP = 6
BACKGROUND = (32, 32, 32)
TEXT = (235, 235, 235)
FONT_PATH = FONT


@dataclass(frozen=True)
class Column:
    """One source of a sheet. Fields: label: up to two lines; rows: (R, h, w, 3) uint8 frames;
    slice: (h, T, 3) uint8 y-t slice."""

    label: tuple[str, ...]
    rows: np.ndarray
    slice: np.ndarray


def cell_size(sides) -> int:
    return int(min(CELL_MAX, max(CELL_MIN, max(sides))))


def _fit(img: np.ndarray, width: int, height: int) -> np.ndarray:
    h, w = img.shape[:2]
    if (w, h) == (width, height):
        return img
    interp = cv2.INTER_AREA if width < w and height < h else cv2.INTER_NEAREST
    return cv2.resize(img, (width, height), interpolation=interp)


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.truetype(str(FONT_PATH), size)
    except OSError:
        return ImageFont.load_default()


def draw_text(img: np.ndarray, lines, x: int, y: int, width: int, size: int = 13) -> np.ndarray:
    """Draw up to a few lines of text into ``img`` (RGB uint8) at (x, y), each cut to ``width`` px."""
    from PIL import Image, ImageDraw

    pil = Image.fromarray(img)
    draw = ImageDraw.Draw(pil)
    font = _font(size)
    for k, line in enumerate(lines):
        text = str(line)
        while text and draw.textlength(text, font=font) > width - 4:
            text = text[:-2] + "…" if len(text) > 2 else ""
        draw.text((x + 2, y + 2 + k * (size + 5)), text, fill=TEXT, font=font)
    return np.asarray(pil).copy()


def comparison_sheet(columns: list[Column], row_labels: list[str]) -> np.ndarray:
    """(LABEL_H + R * cell, C * cell, 3) uint8 sheet; ``row_labels`` are drawn in the first column."""
    cell = cell_size(c.rows.shape[1] for c in columns)
    R = len(row_labels)
    out = np.full((LABEL_H + R * cell, len(columns) * cell, 3), BACKGROUND, np.uint8)
    for j, col in enumerate(columns):
        x = j * cell
        out = draw_text(out, col.label, x, 0, cell)
        for r in range(R):
            y = LABEL_H + r * cell
            out[y:y + cell, x:x + cell] = _fit(col.rows[r], cell, cell)
        out[LABEL_H:, x] = BACKGROUND  # a thin line between columns
    for r, label in enumerate(row_labels):
        out = draw_text(out, [label], 0, LABEL_H + r * cell, cell, size=11)
    return out


def slice_panel_width(frames: int) -> tuple[int, int]:
    """(pixels per frame, panel width) of a y-t panel for a sequence of ``frames`` frames."""
    per = max(1, math.ceil(SLICE_MIN_W / frames))
    return per, max(frames * per, PANEL_MIN_W)


def yt_slices(columns: list[Column], caption: tuple[str, ...]) -> np.ndarray:
    """(LABEL_H + cell + CAPTION_H, C * panel + (C - 1) * GAP, 3) uint8 image of the y-t panels."""
    cell = cell_size(c.slice.shape[0] for c in columns)
    T = columns[0].slice.shape[1]
    per, panel = slice_panel_width(T)
    width = len(columns) * panel + (len(columns) - 1) * GAP
    out = np.full((LABEL_H + cell + CAPTION_H, width, 3), BACKGROUND, np.uint8)
    for j, col in enumerate(columns):
        x = j * (panel + GAP)
        out = draw_text(out, col.label, x, 0, panel)
        strip = _fit(np.repeat(col.slice, per, axis=1), T * per, cell)
        x0 = x + (panel - T * per) // 2
        out[LABEL_H:LABEL_H + cell, x0:x0 + T * per] = strip
    return draw_text(out, caption, 0, LABEL_H + cell, width, size=11)


HEAD_CELL = 224  # enlarged head crops: a 40-100 px head at native size shows its pixels


def head_sheet(columns: list[tuple[tuple[str, ...], dict]], rows: list[int], row_labels: list[str]) -> np.ndarray:
    """(LABEL_H + R * HEAD_CELL, C * HEAD_CELL, 3) uint8: each column's head crop of each row
    enlarged (nearest neighbour, so the pixels stay visible). ``columns``: (label, {row: (h, h, 3)
    uint8 crop}); a missing crop leaves its cell blank."""
    cell = HEAD_CELL
    out = np.full((LABEL_H + len(rows) * cell, len(columns) * cell, 3), BACKGROUND, np.uint8)
    for j, (label, crops) in enumerate(columns):
        x = j * cell
        out = draw_text(out, label, x, 0, cell)
        for r, row in enumerate(rows):
            if row in crops:
                y = LABEL_H + r * cell
                out[y:y + cell, x:x + cell] = cv2.resize(crops[row], (cell, cell), interpolation=cv2.INTER_NEAREST)
        out[LABEL_H:, x] = BACKGROUND
    for r, label in enumerate(row_labels):
        out = draw_text(out, [label], 0, LABEL_H + r * cell, cell, size=11)
    return out
