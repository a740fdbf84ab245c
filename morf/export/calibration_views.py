"""int8 calibration views at the scales the player draws, not only at the training crop's.

The renderer is trained on the training crop (``resolution``) and on zoomed crops
(``zoom_resolution``); the player draws the body up to that largest scale (``trained_scale`` in the
manifest, :mod:`morf.raster.view_scale`), e.g. at 640 x 640. Activation ranges calibrated only on
the training crop's views miss what the network computes on a body twice as large: on the default
capture's `cpu` avatar the int8 mask's outline came out noisy at 640 px, 34.9 dB from fp32 over the
person against 46.2 at 256 px (docs/playback.md). So the exporter calibrates on both:

- the training-crop views, four to a canvas of twice the side (:func:`mosaic`: the same pixels,
  four times fewer calibration runs, and one tensor shape for the calibrator), and
- the same poses seen ``zoom`` times closer (:func:`zoomed_camera`), on a canvas of the same size,
  and half as many halfway there (:func:`closer_scales`; a third scale lifted every size on that
  avatar by 0.4-1.9 dB, 384 px the most).
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from morf.raster.texture_quant import ZERO_POINT

CANVAS = 2  # canvas side / training-crop side: four crops to a mosaic, a zoomed view up to 2x whole


def playback_zoom(camera, transls: Sequence[np.ndarray], max_pixels_per_metre: float | None) -> float:
    """How much closer than the training views the player may draw the body: the largest trained
    scale over the views' median scale at their root (1 when unknown or smaller)."""
    from morf.raster.view_scale import pixels_per_metre

    scales = [pixels_per_metre(camera, t) for t in transls]
    scales = [s for s in scales if s > 0]
    if not max_pixels_per_metre or not scales:
        return 1.0
    return max(1.0, float(max_pixels_per_metre) / float(np.median(scales)))


def closer_scales(zoom: float) -> tuple[tuple[float, float], ...]:
    """(zoom, share of the closer calibration views) beyond the training views' own scale:
    halfway there (the geometric mean, half as many views) and all the way to ``zoom``."""
    return ((float(np.sqrt(zoom)), 0.5), (float(zoom), 1.0))


def zoomed_camera(camera, zoom: float):
    """``camera`` looking ``zoom`` times closer (focal lengths times zoom) on a canvas ``CANVAS``
    times its side, the principal point moved with the canvas so the body stays centred."""
    return dataclasses.replace(camera, fx=camera.fx * zoom, fy=camera.fy * zoom, cx=camera.cx * CANVAS,
                               cy=camera.cy * CANVAS, width=camera.width * CANVAS, height=camera.height * CANVAS)


def mosaic(rasters: Sequence[np.ndarray]) -> list[np.ndarray]:
    """uint8 (1, C, H, W) rasterizations four to a (1, C, 2H, 2W) canvas (row-major), missing tiles
    background (the zero point)."""
    out = []
    for i in range(0, len(rasters), CANVAS * CANVAS):
        group = rasters[i:i + CANVAS * CANVAS]
        _, c, h, w = group[0].shape
        canvas = np.full((1, c, CANVAS * h, CANVAS * w), ZERO_POINT, np.uint8)
        for k, r in enumerate(group):
            y, x = divmod(k, CANVAS)
            canvas[:, :, y * h:(y + 1) * h, x * w:(x + 1) * w] = r
        out.append(canvas)
    return out
