"""How large a camera shows the body, and a close-up drawn at the scale the renderer was trained at.

The neural renderer learns the body at the scales of its training frames (``resolution`` and the
``zoom_resolution`` crops). Much closer than that it sees texels spread over many more pixels
than ever in training and its mask breaks up into holes. The exporter records the largest scale
of training (pixels per metre at the body's root, :func:`pixels_per_metre`) in the avatar folder;
for a closer camera the player draws a wider view at that scale and enlarges the part the camera
asked for (:func:`close_up`): softer, but whole. Torch-free.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from morf.camera import PinholeCamera


def pixels_per_metre(camera: PinholeCamera, point) -> float:
    """Image pixels a metre spans at ``point`` (world, metres) seen by ``camera``: fy / depth;
    0 for a point at or behind the camera."""
    p = np.asarray(camera.R, float) @ np.asarray(point, float).reshape(3) + np.asarray(camera.t, float).reshape(3)
    return float(camera.fy / p[2]) if p[2] > 1e-6 else 0.0


# The renderer holds a little past its largest training scale: on the demo's avatar no hole at
# 1.26x that scale, the first specks at 1.5x, holes from 1.7x (docs/playback.md). Closer views
# are drawn at this multiple of it.
MARGIN = 1.25


@dataclass(frozen=True)
class CloseUp:
    """A closer view than the renderer was trained for, drawn through a wider one.

    Fields:
        camera: the wider camera (same size and principal point, focal lengths divided by ``factor``);
        factor: how much closer the asked camera is than the trained scale (> 1);
        box: (x0, y0, x1, y1) float pixels of the wider image that the asked camera shows.
    """

    camera: PinholeCamera
    factor: float
    box: tuple[float, float, float, float]


def close_up(camera: PinholeCamera, point, max_pixels_per_metre: float | None,
             margin: float = MARGIN) -> CloseUp | None:
    """The :class:`CloseUp` for ``camera`` looking at the body at ``point``, or None when the body
    is shown at no more than ``margin`` times ``max_pixels_per_metre`` (or the limit is unknown)."""
    if not max_pixels_per_metre:
        return None
    limit = max_pixels_per_metre * margin
    scale = pixels_per_metre(camera, point)
    if scale <= limit:
        return None
    f = scale / limit
    wide = dataclasses.replace(camera, fx=camera.fx / f, fy=camera.fy / f)
    x0, y0 = camera.cx - camera.cx / f, camera.cy - camera.cy / f
    box = (x0, y0, x0 + camera.width / f, y0 + camera.height / f)
    return CloseUp(wide, f, box)


def enlarge(image: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray:
    """The ``box`` of ``image`` (H, W, 3) uint8, resampled bilinearly to the image's own size."""
    import cv2

    h, w = image.shape[:2]
    x0, y0, x1, y1 = box
    sx, sy = (x1 - x0) / w, (y1 - y0) / h
    # output pixel centre u maps to input x0 + (u + 0.5) * sx - 0.5
    m = np.array([[sx, 0.0, x0 + 0.5 * sx - 0.5], [0.0, sy, y0 + 0.5 * sy - 0.5]], np.float64)
    return cv2.warpAffine(image, m, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                          borderMode=cv2.BORDER_REPLICATE)
