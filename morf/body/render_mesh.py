"""The render mesh: seams split so that every render vertex carries exactly one UV.

Anny stores UVs per face corner; a rasterizer and a vertex shader want one UV per vertex, so
vertices on UV seams are duplicated (13,718 -> about 14,900 vertices for Anny).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.records import length_of


@dataclass(frozen=True)
class RenderMesh:
    """Mesh topology for rasterization and GPU skinning.

    Fields:
        vertex_map: (Vr,) int64, index of the model vertex each render vertex copies.
        uvs: (Vr, 2) float32 texture coordinates in [0, 1], v up (texture row = (1 - v) * H).
        faces: (F, 3) int32 triangles over render vertices.
        bone_indices: (Vr, K) int32 the K most important bones per render vertex.
        bone_weights: (Vr, K) float32 their weights, renormalised to sum to 1.
    """

    vertex_map: np.ndarray
    uvs: np.ndarray
    faces: np.ndarray
    bone_indices: np.ndarray
    bone_weights: np.ndarray

    num_vertices = length_of("vertex_map")

    def gather(self, model_vertices: torch.Tensor) -> torch.Tensor:
        """(B, V, 3) model-topology vertices -> (B, Vr, 3) render vertices."""
        idx = torch.as_tensor(self.vertex_map, device=model_vertices.device)
        return model_vertices[:, idx]


def build_render_mesh(faces: torch.Tensor, face_uvs: torch.Tensor, uvs: torch.Tensor,
                      dense_weights: torch.Tensor, top_k: int = 8) -> RenderMesh:
    """Split UV seams and keep the ``top_k`` skinning weights per vertex.

    Args:
        faces: (F, 3) model vertex indices; face_uvs: (F, 3) indices into ``uvs`` (T, 2);
        dense_weights: (V, J) skinning weights.
    """
    f = faces.cpu().numpy().astype(np.int64)
    fu = face_uvs.cpu().numpy().astype(np.int64)
    pairs = np.stack([f.reshape(-1), fu.reshape(-1)], axis=1)
    unique, inverse = np.unique(pairs, axis=0, return_inverse=True)
    vertex_map = unique[:, 0]
    render_uvs = uvs.cpu().numpy()[unique[:, 1]].astype(np.float32)
    render_faces = inverse.reshape(-1, 3).astype(np.int32)

    w = dense_weights.cpu().numpy()[vertex_map]
    k = min(top_k, w.shape[1])
    idx = np.argsort(-w, axis=1)[:, :k]
    vals = np.take_along_axis(w, idx, axis=1)
    vals = vals / np.clip(vals.sum(1, keepdims=True), 1e-8, None)
    return RenderMesh(vertex_map=vertex_map, uvs=render_uvs, faces=render_faces,
                      bone_indices=idx.astype(np.int32), bone_weights=vals.astype(np.float32))


def render_mesh_for(model) -> RenderMesh:
    """The render mesh of a :class:`~morf.body.model.BodyModel` (cached on the instance)."""
    cached = getattr(model, "_render_mesh", None)
    if cached is None:
        cached = build_render_mesh(model.faces, model.face_uvs, model.uvs, model.dense_weights)
        object.__setattr__(model, "_render_mesh", cached)
    return cached
