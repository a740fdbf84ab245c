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
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(f"not a readable mask image: {path}")
    if img.shape[1] != width or img.shape[0] != height:
        raise InputError(f"mask {path.name} is {img.shape[1]}x{img.shape[0]} but the frames are {width}x{height}")
    if img.dtype != np.uint8:  # 16-bit or float masks: scale to 0..255
        img = cv2.normalize(img.astype(np.float32), None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    if img.ndim == 3 and img.shape[2] == 4 and img[..., 3].min() != img[..., 3].max():
        return img[..., 3] > 127  # a cut-out: the alpha channel is the mask
    if img.ndim == 3:
        img = img[..., :3].max(axis=2)  # any coloured label counts as the person
    return img > 127


def resize_mask(mask: np.ndarray, width: int, height: int) -> np.ndarray:
    """(H, W) bool -> (height, width) bool, area-averaged then thresholded at half."""
    if mask.shape == (height, width):
        return mask
    m = cv2.resize(mask.astype(np.float32), (width, height), interpolation=cv2.INTER_AREA)
    return m > 0.5


MASK_EXTS = IMAGE_EXTS
