"""Image files: RGB uint8 in, RGB uint8 out (OpenCV underneath, which speaks BGR); and the grey
form of an RGB image that OpenCV's optical flow reads."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from morf.errors import InputError
from morf.io.atomic import atomic_path


def grey_uint8(rgb01: np.ndarray) -> np.ndarray:
    """(H, W, 3) RGB float in [0, 1] -> (H, W) uint8 grey (clipped, rounded), as DIS optical flow reads it."""
    return cv2.cvtColor((np.clip(rgb01, 0, 1) * 255 + 0.5).astype(np.uint8), cv2.COLOR_RGB2GRAY)


def read_image(path: str | os.PathLike, *, grayscale: bool = False) -> np.ndarray:
    """Read an image as (H, W, 3) RGB uint8, or (H, W) uint8 with ``grayscale``.

    An alpha channel is dropped for RGB reads (use ``read_rgba`` for it).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"image not found: {path}")
    flag = cv2.IMREAD_GRAYSCALE if grayscale else cv2.IMREAD_COLOR
    img = cv2.imread(str(path), flag)
    if img is None:
        raise InputError(f"not a readable image: {path}")
    if img.dtype != np.uint8:
        img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    return img if grayscale else cv2.cvtColor(img, cv2.COLOR_BGR2RGB)


def read_rgba(path: str | os.PathLike) -> np.ndarray:
    """Read an image keeping alpha: (H, W, 4) RGBA uint8 (alpha 255 when absent)."""
    path = Path(path)
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(f"not a readable image: {path}")
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGRA)
    elif img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2BGRA)
    return cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA)


def write_image(path: str | os.PathLike, img: np.ndarray, *, jpeg_quality: int = 95) -> None:
    """Atomically write an (H, W, 3) RGB or (H, W) gray uint8 image; format from the suffix."""
    img = np.asarray(img)
    if img.dtype != np.uint8:
        raise TypeError(f"write_image wants uint8, got {img.dtype}")
    out = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
    suffix = str(path).lower()
    if suffix.endswith((".jpg", ".jpeg")):
        params = [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality]
    elif suffix.endswith(".png"):
        # Level 1 is several times faster than OpenCV's default 3 for a few percent more bytes.
        params = [cv2.IMWRITE_PNG_COMPRESSION, 1]
    else:
        params = []
    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), out, params):
            raise OSError(f"cannot write image {path}")
