"""GL textures for images: decoded by the loader thread, uploaded here a few per frame.

Uploading a large frame costs milliseconds, so only about ``upload_budget`` bytes go up per UI
frame; thumbnails stay cached for the life of the project, large images in a small LRU.
"""

from __future__ import annotations

from collections import OrderedDict

import moderngl
import numpy as np

from studio.loader import MISSING, ImageLoader, Key


def upload(ctx: moderngl.Context, image: np.ndarray, texture: moderngl.Texture | None = None) -> moderngl.Texture:
    """(H, W, 3|4) uint8 -> texture (reused when it has the same size and channels)."""
    image = np.asarray(image)
    if image.dtype != np.uint8:  # previews may come as floats in [0, 1]
        image = (np.clip(image, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if image.ndim == 2:
        image = np.repeat(image[..., None], 3, axis=2)
    image = np.ascontiguousarray(image)
    h, w, c = image.shape
    if texture is None or texture.size != (w, h) or texture.components != c:
        if texture is not None:
            texture.release()
        texture = ctx.texture((w, h), c, alignment=1)
        texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
    texture.write(image.tobytes(), alignment=1)
    return texture


class TextureCache:
    """Textures of project images (through an :class:`ImageLoader`) and of preview images."""

    def __init__(self, ctx: moderngl.Context, loader: ImageLoader | None, upload_budget: int = 4 << 20,
                 max_large: int = 24):
        self._ctx = ctx
        self._loader = loader
        self._budget = upload_budget
        self._max_large = max_large
        self._thumbs: dict[Key, moderngl.Texture | None] = {}
        self._large: "OrderedDict[Key, moderngl.Texture | None]" = OrderedDict()
        self._requested: set[Key] = set()
        self._previews: dict[str, tuple[int, moderngl.Texture]] = {}
        self._ring_pos: dict[str, int] = {}  # preview name -> next ring slot

    # ---- project images -------------------------------------------------------------------
    def get(self, key: Key) -> moderngl.Texture | None:
        """The texture for ``key`` if uploaded; otherwise ask the loader and return None.

        A file that does not exist or cannot be read also gives None (once decoded, not re-asked).
        """
        store = self._thumbs if key[0] == "thumb" else self._large
        if key in store:
            if store is self._large:
                self._large.move_to_end(key)
            return store[key]
        if key not in self._requested and self._loader is not None:
            self._requested.add(key)
            self._loader.request(key)
        return None

    def known(self, key: Key) -> bool:
        """True once ``key`` was decoded (even if the file was missing)."""
        return key in self._thumbs or key in self._large

    def pump(self) -> None:
        """Upload decoded images, about ``upload_budget`` bytes per call; call once per UI frame."""
        if self._loader is None:
            return
        spent = 0
        while spent < self._budget:
            ready = self._loader.take_ready(1)
            if not ready:
                return
            key, image = ready[0]
            spent += image.nbytes
            self._requested.discard(key)
            tex = None if image is MISSING or image.size == 0 else upload(self._ctx, image)
            if key[0] == "thumb":
                self._thumbs[key] = tex
            else:
                self._large[key] = tex
                while len(self._large) > self._max_large:
                    _, old = self._large.popitem(last=False)
                    if old is not None:
                        old.release()

    def backlog(self) -> bool:
        """Decoded images wait for a later frame's upload budget."""
        return self._loader is not None and self._loader.has_ready()

    def settled(self) -> bool:
        """Nothing requested is still on its way (for tests and screenshots)."""
        return not self._requested and (self._loader is None or self._loader.idle())

    # ---- preview images from worker snapshots -------------------------------------------
    def preview(self, name: str, image: np.ndarray, version: int, ring: int = 1) -> moderngl.Texture:
        """Texture of a preview image; re-uploaded only when ``version`` changed.

        ``ring`` > 1 cycles through that many textures. For images that change every frame (the
        live render): writing a texture the last frame still draws makes the driver wait for that
        frame's rasterization (measured: 100+ ms on llvmpipe with the CPU busy), while writing
        one last used ``ring - 1`` frames ago does not.
        """
        old = self._previews.get(name)
        if old is not None and old[0] == version:
            return old[1]
        slot = name
        if ring > 1:
            k = self._ring_pos.get(name, 0)
            self._ring_pos[name] = (k + 1) % ring
            slot = f"{name}#{k}"
        prev = self._previews.get(slot)
        tex = upload(self._ctx, image, prev[1] if prev else None)
        self._previews[slot] = self._previews[name] = (version, tex)
        return tex

    def release(self) -> None:
        previews = {id(t): t for _, t in self._previews.values()}.values()  # ring slots appear twice
        for tex in list(self._thumbs.values()) + list(self._large.values()) + list(previews):
            if tex is not None:
                tex.release()
        self._thumbs.clear()
        self._large.clear()
        self._previews.clear()
        self._ring_pos.clear()
        self._requested.clear()
