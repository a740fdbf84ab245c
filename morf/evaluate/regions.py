"""The head, the hands and the person of a frame as boxes, from the frame's rasterized fit.

Each rasterized pixel's part is looked up from its UV in the body model's part atlas
(:func:`morf.body.parts.pixel_parts`), so a box holds only what the fitted mesh shows of that
part in that frame (a hand behind the back has no box). The box is grown by a margin, because
hair, a hood or a sleeve reach past the mesh and a fit is a few pixels off, and kept inside the
image.
"""

from __future__ import annotations

import numpy as np

from morf.body.parts import PARTS

# how far each region's box is grown on every side, as a fraction of its larger side
MARGIN = {"head": 0.2, "hand.L": 0.3, "hand.R": 0.3, "person": 0.05}
MIN_PIXELS = 24  # visible part pixels a region needs to be scored
MIN_SIDE = 8  # and its box's smaller side, in pixels
GROUPS = {"person": ("person",), "head": ("head",), "hands": ("hand.L", "hand.R")}  # what a score averages over


def grown_box(ys: np.ndarray, xs: np.ndarray, margin: float, height: int, width: int) -> tuple[int, int, int, int]:
    """(y0, x0, y1, x1), end exclusive: the pixels' bounding box grown by ``margin`` of its larger
    side on every side, clipped to the image."""
    y0, y1, x0, x1 = int(ys.min()), int(ys.max()) + 1, int(xs.min()), int(xs.max()) + 1
    g = int(round(margin * max(y1 - y0, x1 - x0)))
    return max(0, y0 - g), max(0, x0 - g), min(height, y1 + g), min(width, x1 + g)


def frame_boxes(parts: np.ndarray, person: np.ndarray) -> dict[str, tuple[int, int, int, int]]:
    """{region: box} of one frame: "head", "hand.L", "hand.R" from ``parts`` (H, W) part codes,
    "person" from ``person`` (H, W) bool (the real mask or the mesh, whichever covers). Regions
    with fewer than ``MIN_PIXELS`` pixels or a box thinner than ``MIN_SIDE`` are left out."""
    H, W = parts.shape
    out = {}
    for name, pixels in [("person", person)] + [(n, parts == c) for n, c in PARTS.items()]:
        if pixels.sum() < MIN_PIXELS:
            continue
        ys, xs = np.nonzero(pixels)
        box = grown_box(ys, xs, MARGIN[name], H, W)
        if min(box[2] - box[0], box[3] - box[1]) >= MIN_SIDE:
            out[name] = box
    return out


def square_box(box, height: int, width: int) -> tuple[int, int, int, int]:
    """The square around ``box``'s centre with its larger side, moved (not cut) to fit the image
    where it can: the shape of a sheet's enlarged crop."""
    y0, x0, y1, x1 = box
    side = min(max(y1 - y0, x1 - x0), height, width)
    cy, cx = (y0 + y1) // 2, (x0 + x1) // 2
    ty = min(max(0, cy - side // 2), height - side)
    tx = min(max(0, cx - side // 2), width - side)
    return ty, tx, ty + side, tx + side
