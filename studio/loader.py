"""A small thread that decodes images (frames, thumbnails, masks, fit overlays) off the UI thread.

The UI asks for keys like ``("thumb", 12)``; the newest request is decoded first (the frame the
user is looking at now matters more than the ones they skipped past). Results wait in a dict
until the UI's texture cache takes them.
"""

from __future__ import annotations

import threading
from typing import Callable

import cv2
import numpy as np

from morf.errors import MorfError
from morf.io.images import read_image, read_rgba

Key = tuple[str, int]  # (kind, frame index); kind: frame | thumb | mask | fit
MISSING = np.zeros((0, 0, 3), np.uint8)  # decoded result for a file that is absent or unreadable

MASK_TINT = (40, 200, 255, 110)  # RGBA of the person-mask overlay


class ImageLoader:
    """Decode project images on one background thread.

    Args:
        paths: kind -> (frame index -> file path) for "frame", "mask" and "fit".
        thumb_height: height of thumbnails in pixels.
        on_ready: called on the loader's thread after each decoded image (wakes the UI's frame loop).
    """

    def __init__(self, paths: dict[str, Callable[[int], object]], thumb_height: int = 72, max_side: int = 1280,
                 on_ready: Callable[[], None] | None = None):
        self._paths = paths
        self._thumb_height = thumb_height
        self._max_side = max_side  # larger frames are shrunk here: uploads stay cheap on the UI thread
        self._on_ready = on_ready
        self._cond = threading.Condition()
        self._wanted: list[Key] = []  # a stack: newest request on top
        self._ready: dict[Key, np.ndarray] = {}
        self._busy = False
        self._closed = False
        self._thread = threading.Thread(target=self._main, name="morf-image-loader", daemon=True)
        self._thread.start()

    def request(self, key: Key) -> None:
        with self._cond:
            if key in self._wanted:
                self._wanted.remove(key)
            self._wanted.append(key)
            self._cond.notify()

    def has_ready(self) -> bool:
        """Decoded images wait to be taken."""
        with self._cond:
            return bool(self._ready)

    def take_ready(self, limit: int) -> list[tuple[Key, np.ndarray]]:
        """Up to ``limit`` decoded images, oldest first; MISSING for files that cannot be read."""
        with self._cond:
            keys = list(self._ready)[:limit]
            return [(k, self._ready.pop(k)) for k in keys]

    def idle(self) -> bool:
        """Nothing requested, nothing being decoded, nothing waiting to be taken."""
        with self._cond:
            return not self._wanted and not self._busy and not self._ready

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(5.0)

    def _main(self) -> None:
        while True:
            with self._cond:
                while not self._wanted and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                key = self._wanted.pop()
                self._busy = True
            try:
                image = self._decode(key)
            except (MorfError, OSError, cv2.error, ValueError):
                image = MISSING
            with self._cond:
                self._ready[key] = image
                self._busy = False
            if self._on_ready is not None:
                self._on_ready()

    def _decode(self, key: Key) -> np.ndarray:
        kind, i = key
        if kind == "thumb":
            rgb = read_image(self._paths["frame"](i))
            h, w = rgb.shape[:2]
            tw = max(1, round(w * self._thumb_height / h))
            return cv2.resize(rgb, (tw, self._thumb_height), interpolation=cv2.INTER_AREA)
        if kind == "mask":
            m = self._shrink(read_image(self._paths["mask"](i), grayscale=True)) > 127
            out = np.zeros(m.shape + (4,), np.uint8)
            out[m] = MASK_TINT
            return out
        if kind == "fit":
            return self._shrink(read_rgba(self._paths["fit"](i)))
        return self._shrink(read_image(self._paths[kind](i)))

    def _shrink(self, image: np.ndarray) -> np.ndarray:
        h, w = image.shape[:2]
        s = self._max_side / max(h, w)
        if s >= 1.0:
            return image
        return cv2.resize(image, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)

