"""Rasterize a mesh's UV layout into texture space: which triangle covers each texel, and where.

Used to write per-vertex values (spectral coordinates) into a texture, and to know which texels
belong to the body at all. Pure numpy: every triangle's bounding box of texel centres is enumerated
at once, so a 27k-triangle atlas at 512x512 takes well under a second.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class UVAtlas:
    """Texture-space rasterization of a mesh.

    Fields:
        face_id: (Ht, Wt) int32, triangle covering the texel centre, -1 outside every UV island.
        bary: (Ht, Wt, 3) float32 barycentric weights of the texel centre in that triangle.
        faces: (F, 3) int64 the triangles (indices into the per-vertex arrays given to interpolate).
    """

    face_id: np.ndarray
    bary: np.ndarray
    faces: np.ndarray

    @property
    def covered(self) -> np.ndarray:
        """(Ht, Wt) bool, texels inside a UV island."""
        return self.face_id >= 0

    def interpolate(self, values: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """(V, C) per-vertex values -> (Ht, Wt, C) barycentric interpolation (``fill`` outside)."""
        values = np.asarray(values, dtype=np.float32)
        out = np.full(self.face_id.shape + (values.shape[1],), fill, dtype=np.float32)
        ok = self.covered
        tri = self.faces[self.face_id[ok]]  # (n, 3)
        b = self.bary[ok]
        out[ok] = (values[tri] * b[..., None]).sum(1)
        return out


def rasterize_uv_atlas(uvs: np.ndarray, faces: np.ndarray, height: int, width: int) -> UVAtlas:
    """Rasterize triangles given by per-vertex UVs (v up) into an (height, width) texel grid.

    Args:
        uvs: (V, 2) UVs in [0, 1], v up (texel row = (1 - v) * height).
        faces: (F, 3) vertex indices.
    """
    uvs = np.asarray(uvs, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    # Texel space: x = u * W, y = (1 - v) * H; texel (r, c) has its centre at (c + 0.5, r + 0.5).
    px = np.stack([uvs[:, 0] * width, (1 - uvs[:, 1]) * height], axis=1)[faces]  # (F, 3, 2)
    lo = np.floor(px.min(1) - 0.5).astype(np.int64) + 1
    hi = np.floor(px.max(1) - 0.5).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [width - 1, height - 1])
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    counts = nx * ny
    tri = np.repeat(np.arange(len(faces)), counts)
    start = np.cumsum(counts) - counts
    local = np.arange(counts.sum()) - np.repeat(start, counts)
    cx = lo[tri, 0] + local % np.repeat(np.maximum(nx, 1), counts)
    cy = lo[tri, 1] + local // np.repeat(np.maximum(nx, 1), counts)
    p = np.stack([cx + 0.5, cy + 0.5], axis=1)
    a, b, c = px[tri, 0], px[tri, 1], px[tri, 2]
    v0, v1, v2 = b - a, c - a, p - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    safe = np.where(np.abs(den) < 1e-12, 1.0, den)
    w1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / safe
    w2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / safe
    w0 = 1 - w1 - w2
    eps = -1e-9
    inside = (np.abs(den) >= 1e-12) & (w0 >= eps) & (w1 >= eps) & (w2 >= eps)
    face_id = np.full((height, width), -1, dtype=np.int32)
    bary = np.zeros((height, width, 3), dtype=np.float32)
    face_id[cy[inside], cx[inside]] = tri[inside]
    bary[cy[inside], cx[inside]] = np.stack([w0, w1, w2], axis=1)[inside]
    return UVAtlas(face_id=face_id, bary=bary, faces=faces)


def dilate_texture(texture: np.ndarray, covered: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """Grow UV islands by ``iterations`` texels: each new texel takes the mean of its covered
    8-neighbours, so bilinear lookups near seams never blend in the empty background.

    Args:
        texture: (Ht, Wt, C) values; covered: (Ht, Wt) bool.
    Returns:
        (texture, covered) after dilation.
    """
    tex = np.where(covered[..., None], texture, 0).astype(np.float32)
    cov = covered.astype(bool).copy()
    H, W = cov.shape
    for _ in range(iterations):
        acc = np.zeros_like(tex)
        cnt = np.zeros((H, W), np.float32)
        padded_t = np.pad(tex * cov[..., None], ((1, 1), (1, 1), (0, 0)))
        padded_c = np.pad(cov.astype(np.float32), 1)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if dy == 0 and dx == 0:
                    continue
                acc += padded_t[1 + dy:1 + dy + H, 1 + dx:1 + dx + W]
                cnt += padded_c[1 + dy:1 + dy + H, 1 + dx:1 + dx + W]
        grow = (~cov) & (cnt > 0)
        if not grow.any():
            break
        tex[grow] = acc[grow] / cnt[grow, None]
        cov = cov | grow
    return tex, cov
