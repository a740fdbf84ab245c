"""Person masks made elsewhere (a matting tool, a segmentation model, hand painting).

Any image format OpenCV reads; a pixel belongs to the person when its value is above half
(gray or colour images), or, for images with a varying alpha channel, when its alpha is.
A mask must have its frame's size (before ``--resize``; the resize is applied to both).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from morf.capture.video import IMAGE_EXTS
from morf.errors import InputError


def read_mask(path: str | Path, width: int, height: int) -> np.ndarray:
    """Read a mask file -> (H, W) bool, checked against the frame size (W, H)."""
    path = Path(path)
    try:  # bytes first: cv2.imread prints a warning of its own for a file it cannot open
        data = np.frombuffer(path.read_bytes(), np.uint8)
    except OSError as e:
        raise InputError(f"cannot read mask {path}: {e.strerror or e}") from None
    img = _decode(data)
    if img is None or img.size == 0:
        raise InputError(f"not a readable mask image: {path} (empty, damaged, or not an image format OpenCV reads: "
                         f"{', '.join(MASK_EXTS)})")
    if img.shape[1] != width or img.shape[0] != height:
        raise InputError(f"mask {path.name} is {img.shape[1]}x{img.shape[0]} but the frames are {width}x{height}; "
                         "each mask must have its frame's size (before --resize)")
    if img.dtype != np.uint8:  # 16-bit or float masks: scale to 0..255
        img = cv2.normalize(img.astype(np.float32), None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    if img.ndim == 3 and img.shape[2] == 4 and img[..., 3].min() != img[..., 3].max():
        return img[..., 3] > 127  # a cut-out: the alpha channel is the mask
    if img.ndim == 3:
        img = img[..., :3].max(axis=2)  # any coloured label counts as the person
    return img > 127


def _decode(data: np.ndarray) -> np.ndarray | None:
    """The image in ``data``, or None; OpenCV's warnings about a damaged file are held back (the
    one-line error says it instead)."""
    if not data.size:
        return None
    log = getattr(getattr(cv2, "utils", None), "logging", None)
    level = log.getLogLevel() if log is not None else None
    if log is not None:
        log.setLogLevel(log.LOG_LEVEL_ERROR)
    try:
        return cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    except cv2.error:
        return None
    finally:
        if log is not None:
            log.setLogLevel(level)


def resize_mask(mask: np.ndarray, width: int, height: int) -> np.ndarray:
    """(H, W) bool -> (height, width) bool, area-averaged then thresholded at half."""
    if mask.shape == (height, width):
        return mask
    m = cv2.resize(mask.astype(np.float32), (width, height), interpolation=cv2.INTER_AREA)
    return m > 0.5


MASK_EXTS = IMAGE_EXTS
