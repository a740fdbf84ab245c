"""Spectral initialisation of the neural texture (StylePeople, MoRF Sec. 3.2).

Each texel starts as the spectral coordinates of its body-surface point: the lowest non-constant
eigenvectors of the mesh graph's combinatorial Laplacian ``L = D - A``. They vary smoothly over the
body and differ between body parts, which slows the renderer's overfitting and helps inpainting.

Anny's mesh has small separate components (eyes, tongue). The eigenvectors are computed on the
largest component (the skin); every other vertex copies the values of its nearest skin vertex in
the rest pose, so an eye looks like its eyelid instead of carrying a component-indicator vector.
The eigenvectors are cached on disk (``$MORF_CACHE_DIR`` or ``~/.cache/morf``).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import eigsh
from scipy.spatial import cKDTree

from morf.avatar.uv_atlas import dilate_texture, rasterize_uv_atlas
from morf.io import load_npz, save_npz


def cache_dir() -> Path:
    return Path(os.environ.get("MORF_CACHE_DIR", Path.home() / ".cache" / "morf"))


def graph_laplacian(faces: np.ndarray, num_vertices: int) -> sp.csr_matrix:
    """(V, V) combinatorial Laplacian ``D - A`` of the mesh's edge graph (unit edge weights)."""
    f = np.asarray(faces, dtype=np.int64)
    i = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    j = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    A = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(num_vertices, num_vertices)).tocsr()
    A = ((A + A.T) > 0).astype(np.float64)
    D = sp.diags(np.asarray(A.sum(1)).ravel())
    return (D - A).tocsr()


def laplacian_eigenvectors(laplacian: sp.spmatrix, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` smallest eigenpairs of a connected graph's Laplacian after the constant one.

    Returns:
        eigenvalues (k,) ascending, eigenvectors (V, k) with unit L2 norm.
    """
    n = laplacian.shape[0]
    if k + 1 >= n:
        vals, vecs = np.linalg.eigh(laplacian.toarray())
    else:
        # Shift-invert around a small negative sigma: L is singular, L - sigma I is not.
        vals, vecs = eigsh(laplacian.astype(np.float64), k=k + 1, sigma=-1e-3, which="LM")
    order = np.argsort(vals)
    vals, vecs = vals[order][1:k + 1], vecs[:, order][:, 1:k + 1]
    return vals, vecs


def mesh_spectral_coordinates(faces: np.ndarray, positions: np.ndarray, k: int) -> np.ndarray:
    """(V, k) spectral coordinates of every vertex, each channel scaled to max |value| = 1.

    Computed on the largest connected component; other vertices copy their nearest neighbour's.
    """
    V = positions.shape[0]
    L = graph_laplacian(faces, V)
    _, labels = connected_components(L != 0, directed=False)
    main = labels == np.bincount(labels).argmax()
    idx = np.flatnonzero(main)
    _, vecs = laplacian_eigenvectors(L[idx][:, idx], k)
    out = np.zeros((V, k))
    out[idx] = vecs
    if not main.all():
        _, nn = cKDTree(positions[idx]).query(positions[~main])
        out[~main] = vecs[nn]
    out /= np.abs(out).max(0, keepdims=True) + 1e-12
    return out.astype(np.float32)


def cached_spectral_coordinates(faces: np.ndarray, positions: np.ndarray, k: int) -> np.ndarray:
    """:func:`mesh_spectral_coordinates` with an on-disk cache keyed by topology and k."""
    key = hashlib.sha1(np.ascontiguousarray(faces, dtype=np.int64).tobytes()).hexdigest()[:16]
    path = cache_dir() / f"spectral_{key}_{positions.shape[0]}_{k}.npz"
    if path.is_file():
        try:
            d = load_npz(path)["coords"]
            if d.shape == (positions.shape[0], k):
                return d
        except Exception:  # a damaged cache is recomputed
            pass
    coords = mesh_spectral_coordinates(faces, positions, k)
    save_npz(path, coords=coords)
    return coords


def spectral_texture(model, channels: int, height: int, width: int, dilate: int = 4) -> np.ndarray:
    """(C, Ht, Wt) float32 spectral texture for a body model, dilated past the UV islands.

    Texels outside every island (after dilation) are 0.
    """
    import torch

    from morf.body.render_mesh import render_mesh_for

    rm = render_mesh_for(model)
    with torch.no_grad():
        rest = model(model.zero_pose(1), model.default_shape()).rest_vertices[0].cpu().numpy()
    coords = cached_spectral_coordinates(model.faces.cpu().numpy(), rest, channels)
    atlas = rasterize_uv_atlas(rm.uvs, rm.faces, height, width)
    tex = atlas.interpolate(coords[rm.vertex_map])
    tex, _ = dilate_texture(tex, atlas.covered, dilate)
    return np.ascontiguousarray(tex.transpose(2, 0, 1))


def body_uv_atlas(model, height: int, width: int):
    """:class:`~morf.avatar.uv_atlas.UVAtlas` of the model's render mesh."""
    from morf.body.render_mesh import render_mesh_for

    rm = render_mesh_for(model)
    return rasterize_uv_atlas(rm.uvs, rm.faces, height, width)
