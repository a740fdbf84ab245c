"""Clothing offsets: one outward displacement per vertex along the rest-pose normal, shared by all frames.

The person masks show the dressed person (loose clothes, hair); the naked body model reaches
only 0.84-0.89 IoU against them even with the true pose and shape. As in SMPL+D, the fit adds a
smooth, outward-only offset per vertex in the rest pose (``v_rest + o * n_rest``), skinned with
the body, so the posed surface follows the clothes while the body underneath (what the vertex
error measures) stays a body.

The offsets are optimised on the silhouette proxy's vertices (a few thousand, see
``proxy_mesh.py``) and spread to the full mesh by inverse-distance weights of the nearest proxy
vertices in the rest pose.
"""

from __future__ import annotations

import threading
import weakref

import numpy as np
import torch


def vertex_normals_torch(vertices: torch.Tensor, faces: torch.Tensor) -> torch.Tensor:
    """(B, V, 3) area-weighted unit vertex normals of (B, V, 3) vertices and (F, 3) faces.

    Anny's triangles are counter-clockwise seen from outside, so the normals point outwards.
    Differentiable; the numpy version is :func:`morf.body.normals.vertex_normals`.
    """
    v = vertices
    fn = torch.linalg.cross(v[:, faces[:, 1]] - v[:, faces[:, 0]], v[:, faces[:, 2]] - v[:, faces[:, 0]])
    n = torch.zeros_like(v)
    for k in range(3):
        n = n.index_add(1, faces[:, k], fn)
    return n / n.norm(dim=-1, keepdim=True).clamp_min(1e-12)


_NORMALS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()  # model -> {shape key: normals}
_NORMALS_LOCK = threading.Lock()
_NORMALS_KEPT = 4  # shapes remembered per model: a capture's one shape, a few in a batch of captures


def rest_normals(model, shape: torch.Tensor) -> torch.Tensor:
    """(1 or B, V, 3) outward normals of the shaped rest mesh (no gradient; do not modify in place).

    Remembered per model for the last few shapes: every frame drawn dressed needs them (training
    data, hold-out and inpainting views, evaluation), and a capture has one shape."""
    key = (str(shape.dtype), str(shape.device), tuple(shape.shape), shape.detach().cpu().numpy().tobytes())
    with _NORMALS_LOCK:  # the studio trains in a worker thread while its panels draw
        try:
            kept = _NORMALS.setdefault(model, {})
        except TypeError:  # a model that cannot be weakly referenced: computed each time
            kept = {}
        normals = kept.get(key)
    if normals is None:
        with torch.no_grad():
            normals = vertex_normals_torch(model.rest(shape)["rest_vertices"], model.faces)
        with _NORMALS_LOCK:
            kept[key] = normals
            while len(kept) > _NORMALS_KEPT:
                kept.pop(next(iter(kept)))
    return normals


def proxy_edges(faces: np.ndarray | torch.Tensor) -> torch.Tensor:
    """(E, 2) long unique undirected edges of a triangle mesh."""
    f = torch.as_tensor(faces).long()
    e = torch.cat([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]).sort(dim=1).values
    return torch.unique(e, dim=0)


def smoothness_loss(offsets: torch.Tensor, edges: torch.Tensor) -> torch.Tensor:
    """Scalar: sum of squared offset differences over mesh edges (the graph Laplacian's energy), m^2."""
    return (offsets[edges[:, 0]] - offsets[edges[:, 1]]).pow(2).sum()


def spread_weights(rest_vertices: torch.Tensor, proxy_ids: torch.Tensor, k: int = 3,
                   chunk: int = 4096) -> tuple[torch.Tensor, torch.Tensor]:
    """Nearest ``k`` proxy vertices of every mesh vertex and their inverse-distance weights.

    Args:
        rest_vertices: (V, 3) rest-pose vertices; proxy_ids: (Vp,) indices of the proxy's vertices.
    Returns:
        (V, k) long proxy-vertex indices, (V, k) float weights summing to 1 (a proxy vertex
        itself gets weight 1 on itself).
    """
    pv = rest_vertices[proxy_ids]
    ids, ws = [], []
    for s in range(0, rest_vertices.shape[0], chunk):
        # exact distances (the matmul form rounds a point's distance to itself to ~1e-3)
        d = torch.cdist(rest_vertices[s:s + chunk], pv, compute_mode="donot_use_mm_for_euclid_dist")
        dk, ik = d.topk(k, dim=1, largest=False)
        w = 1.0 / (dk + 1e-4)
        w = torch.where(dk[:, :1] < 1e-6, (torch.arange(k) == 0).to(w.dtype).expand_as(w), w)
        ids.append(ik)
        ws.append(w / w.sum(1, keepdim=True))
    return torch.cat(ids), torch.cat(ws)


def spread_to_mesh(model, proxy_ids: np.ndarray | torch.Tensor, proxy_offsets: torch.Tensor) -> torch.Tensor:
    """(V,) offsets of every model vertex from (Vp,) offsets of the proxy's vertices."""
    with torch.no_grad():
        rest = model.rest(model.default_shape())["rest_vertices"][0]
        ids, w = spread_weights(rest.cpu(), torch.as_tensor(proxy_ids).long().cpu())
        return (proxy_offsets.detach().cpu()[ids] * w).sum(1)


def offset_displacement(bone_transforms: torch.Tensor, weights: torch.Tensor, normals: torch.Tensor,
                        offsets: torch.Tensor) -> torch.Tensor:
    """(B, V, 3) world displacement of each posed vertex by its rest-pose offset.

    LBS is linear, so skinning ``v_rest + o n`` adds the blended rotation applied to ``o n``.

    Args:
        bone_transforms: (B, J, 4, 4) skinning matrices (``BodyOutput.bone_transforms``).
        weights: (V, J) skinning weights (``model.dense_weights``).
        normals: (1 or B, V, 3) rest normals (:func:`rest_normals`).
        offsets: (V,) metres along the normals.
    """
    B, J = bone_transforms.shape[:2]
    R = (weights @ bone_transforms[:, :, :3, :3].reshape(B, J, 9)).reshape(B, -1, 3, 3)
    return (R @ (offsets[:, None] * normals).unsqueeze(-1)).squeeze(-1)


def dressed_rest_vertices(model, shape: torch.Tensor, offsets: np.ndarray | torch.Tensor | None) -> torch.Tensor:
    """(1, V, 3) shaped rest vertices moved outward by ``offsets`` (V,) metres along the rest normals.

    This is the surface the avatar carries (training rasterizes it posed, the avatar folder's
    mesh.npz stores it), so a hood or a loose hem the naked body lacks gets texels instead of being
    cut away by the mask. Skinning these vertices gives exactly :func:`dressed_vertices` (LBS is
    linear). Without offsets (None) these are the body's own rest vertices.
    """
    with torch.no_grad():
        rest = model.rest(shape)["rest_vertices"][:1]
        if offsets is None:
            return rest
        o = torch.as_tensor(np.asarray(offsets), dtype=rest.dtype, device=rest.device)
        return rest + o[None, :, None] * rest_normals(model, shape)[:1]


def offset_summary(offsets: np.ndarray | None) -> dict:
    """``{"dressed", "offset_mean_mm", "offset_max_mm"}`` of clothing offsets (V,) metres, for
    manifests and logs; ``dressed`` is False (and the sizes None) without offsets."""
    if offsets is None:
        return {"dressed": False, "offset_mean_mm": None, "offset_max_mm": None}
    o = np.asarray(offsets, np.float64)
    return {"dressed": True, "offset_mean_mm": round(float(o.mean()) * 1000, 2),
            "offset_max_mm": round(float(o.max()) * 1000, 2)}


def dressed_vertices(model, out, shape: torch.Tensor, offsets: torch.Tensor | None) -> torch.Tensor:
    """(B, V, 3) posed vertices of the offset ("dressed") surface; ``out`` is ``model(pose, shape)``.

    Without offsets (None) these are the body's own vertices.
    """
    if offsets is None:
        return out.vertices
    o = torch.as_tensor(offsets, dtype=out.vertices.dtype, device=out.vertices.device)
    return out.vertices + offset_displacement(out.bone_transforms, model.dense_weights, rest_normals(model, shape), o)
