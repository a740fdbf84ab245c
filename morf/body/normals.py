"""Vertex normals of a triangle mesh in numpy (float64), for code that holds plain arrays.

The torch version that fitting differentiates through is
:func:`morf.fitting.offsets.vertex_normals_torch`.
"""

from __future__ import annotations

import numpy as np


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals: (V, 3) or (B, V, 3) vertices, (F, 3) faces -> the
    vertices' shape, float64."""
    v = np.asarray(vertices, np.float64)
    single = v.ndim == 2
    if single:
        v = v[None]
    faces = np.asarray(faces, np.int64)
    B, V = v.shape[:2]
    fn = np.cross(v[:, faces[:, 1]] - v[:, faces[:, 0]], v[:, faces[:, 2]] - v[:, faces[:, 0]])  # (B, F, 3)
    idx = (np.arange(B)[:, None, None] * V + faces[None]).reshape(-1)  # every corner of every face
    n = np.stack([np.bincount(idx, np.repeat(fn[..., k].reshape(-1), 3), minlength=B * V) for k in range(3)], -1)
    n = n.reshape(B, V, 3)
    n = n / np.clip(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12, None)
    return n[0] if single else n
