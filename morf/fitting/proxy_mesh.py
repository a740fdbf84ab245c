"""A coarse proxy of the body mesh for the silhouette loss (vertex clustering).

The silhouette loss runs at 64-128 px, where Anny's 27k triangles are far below a pixel each;
a proxy with a few thousand triangles has the same outline to within a few millimetres and is
several times cheaper to skin and to rasterize. Proxy vertices are real model vertices (one
representative per grid cell), so they are posed by the model's own skinning.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch


@dataclass(frozen=True)
class ProxyMesh:
    """Fields:
        vertex_ids: (Vp,) int64, model vertex index of each proxy vertex.
        faces: (Fp, 3) int64 triangles over proxy vertices.
    """

    vertex_ids: np.ndarray
    faces: np.ndarray

    @property
    def num_faces(self) -> int:
        return int(self.faces.shape[0])


def cluster_mesh(vertices: np.ndarray, faces: np.ndarray, cell: float) -> ProxyMesh:
    """Vertex clustering on a ``cell``-metre grid.

    Args:
        vertices: (V, 3) rest-pose vertices; faces: (F, 3) triangles.
    Returns:
        The proxy: one representative vertex per occupied cell (the one nearest the cell's mean),
        triangles whose corners fall in three different cells, duplicates removed.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if cell <= 0:
        return ProxyMesh(np.arange(len(vertices)), faces.copy())
    keys = np.floor((vertices - vertices.min(0)) / cell).astype(np.int64)
    _, cluster, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    cluster = cluster.reshape(-1)
    n = counts.shape[0]
    means = np.zeros((n, 3))
    np.add.at(means, cluster, vertices)
    means /= counts[:, None]
    dist = np.linalg.norm(vertices - means[cluster], axis=1)
    # representative: for each cluster the member with the smallest distance to the mean
    order = np.lexsort((dist, cluster))
    first = np.ones(len(order), bool)
    first[1:] = cluster[order][1:] != cluster[order][:-1]
    rep = np.empty(n, np.int64)
    rep[cluster[order][first]] = order[first]
    f = cluster[faces]
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f = f[ok]
    canon = np.sort(f, axis=1)
    _, keep = np.unique(canon, axis=0, return_index=True)
    f = f[np.sort(keep)]
    used = np.unique(f)
    remap = -np.ones(n, np.int64)
    remap[used] = np.arange(len(used))
    return ProxyMesh(vertex_ids=rep[used], faces=remap[f])


def body_proxy(model, cell: float = 0.025) -> ProxyMesh:
    """The proxy of a body model's rest mesh at its default shape (cached per cell size)."""
    cache = getattr(model, "_proxy_cache", None)
    if cache is None:
        cache = {}
        object.__setattr__(model, "_proxy_cache", cache)
    if cell not in cache:
        with torch.no_grad():
            rest = model.rest(model.default_shape())["rest_vertices"][0].cpu().numpy()
        cache[cell] = cluster_mesh(rest, model.faces.cpu().numpy(), cell)
    return cache[cell]
