"""The body as fitting sees it: only the vertices the losses need, skinned sparsely.

A full Anny forward pass skins 13.7k vertices against 104 bones with dense weights; fitting
needs the 23 keypoints (each a weighted mean of a few hundred vertices once the regressor's
negligible weights are pruned) and the silhouette proxy's vertices. Skinning those few
thousand vertices with Anny's sparse (at most 9 bones per vertex) weights makes a fitting step
many times cheaper than ``model(pose, shape)``, with the same result to well under a millimetre.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from morf.body.model import BodyPose, PoseMatrices
from morf.fitting.offsets import vertex_normals_torch
from morf.fitting.proxy_mesh import ProxyMesh


@dataclass(frozen=True)
class FitBodyOutput:
    """Fields:
        keypoints3d: (B, 23, 3) world keypoints (COCO-17 + feet).
        proxy_vertices: (P, Vp, 3) posed vertices of the silhouette proxy for the requested rows.
        head_rotation: (B, 3, 3) the head bone's skinning rotation (what turns points fixed to the
            head, :func:`morf.fitting.face_visibility.detector_ears`).
    """

    keypoints3d: torch.Tensor
    proxy_vertices: torch.Tensor
    head_rotation: torch.Tensor


def prune_regressor(regressor: torch.Tensor, mass: float = 0.999) -> torch.Tensor:
    """(K, V) keypoint regressor keeping, per row, the largest weights that hold ``mass`` of it.

    Rows are renormalised to sum to 1 so pruned keypoints stay affine combinations.
    """
    out = torch.zeros_like(regressor)
    for k in range(regressor.shape[0]):
        r = regressor[k]
        vals, idx = r.abs().sort(descending=True)
        n = int((torch.cumsum(vals, 0) < mass * vals.sum()).sum()) + 1
        out[k, idx[:n]] = r[idx[:n]]
    return out / out.sum(1, keepdim=True)


class FitBody(torch.nn.Module):
    """Poses the keypoints and the proxy vertices of a body model from axis-angle parameters.

    With one shared shape the keypoints never need posed vertices: LBS is linear, so
    ``kp_k = sum_j T_j @ A_kj`` with ``A_kj = sum_v R_kv w_vj [v_rest; 1]`` (K x J x 4, computed
    once per step from the shaped rest vertices) -- about 100k multiply-adds per frame instead
    of skinning a few thousand vertices. Per-frame shapes fall back to skinning the regressor's
    vertices.
    """

    def __init__(self, model, proxy: ProxyMesh | None = None, regressor_mass: float = 0.999):
        super().__init__()
        self.model = model
        self.head = model.bone_index("head")
        reg = prune_regressor(model.keypoint_regressor, regressor_mass)
        kp_ids = torch.nonzero(reg.abs().sum(0) > 0).squeeze(1)
        self.register_buffer("kp_ids", kp_ids, persistent=False)
        self.register_buffer("regressor", reg[:, kp_ids].contiguous(), persistent=False)
        self.register_buffer("kp_weights", model.dense_weights[kp_ids].contiguous(), persistent=False)
        if proxy is not None:
            ids = torch.as_tensor(proxy.vertex_ids, device=kp_ids.device)
            self.register_buffer("proxy_ids", ids, persistent=False)
            self.register_buffer("proxy_weights", model.dense_weights[ids].contiguous(), persistent=False)
            self.register_buffer("proxy_faces", torch.as_tensor(proxy.faces, device=kp_ids.device), persistent=False)
            # the full mesh's triangles around the proxy's vertices: all that their rest normals need
            touches = torch.zeros(model.num_vertices, dtype=torch.bool, device=kp_ids.device)
            touches[ids] = True
            self.register_buffer("normal_faces", model.faces[touches[model.faces].any(1)].contiguous(),
                                 persistent=False)
        else:
            self.proxy_ids = self.proxy_weights = self.proxy_faces = self.normal_faces = None

    def forward(self, pose: BodyPose | PoseMatrices, shape: torch.Tensor, proxy_rows: torch.Tensor | None = None,
                proxy_offsets: torch.Tensor | None = None) -> FitBodyOutput:
        """``pose``: (B, J, 3) rotvecs or (B, J, 3, 3) matrices + (B, 3) transl; ``shape``: (1, S)
        shared or (B, S).

        ``proxy_rows``: (P,) batch rows whose proxy vertices are needed (default: all rows).
        ``proxy_offsets``: optional (Vp,) clothing offsets of the proxy vertices, metres along the
        rest-pose normals (see ``offsets.py``).
        """
        model = self.model
        rest = self._rest(shape)
        T, _ = model.bone_transforms(pose, rest["rest_bone_poses"])
        T34 = T[:, :, :3, :]  # (B, J, 3, 4)
        rest_v = rest["rest_vertices"]
        kv = rest_v[:, self.kp_ids]
        if kv.shape[0] == 1:
            A = rest.get("keypoint_basis")
            if A is None:
                A = self._keypoint_basis(kv[0])
            kp = torch.einsum("bjcd,kjd->bkc", T34, A)
        else:
            kp = torch.einsum("kv,bvc->bkc", self.regressor, _skin(T34, self.kp_weights, kv))
        proxy = kp.new_zeros(0, 0, 3)
        if self.proxy_ids is not None and (proxy_rows is None or proxy_rows.numel() > 0):
            rows = slice(None) if proxy_rows is None else proxy_rows
            pv = rest_v[:, self.proxy_ids]
            if proxy_offsets is not None:
                normals = vertex_normals_torch(rest_v.detach(), self.normal_faces)[:, self.proxy_ids]
                pv = pv + proxy_offsets[None, :, None] * normals
            proxy = _skin(T34[rows], self.proxy_weights, pv if pv.shape[0] == 1 else pv[rows])
        return FitBodyOutput(keypoints3d=kp, proxy_vertices=proxy, head_rotation=T34[:, self.head, :, :3])


    def _rest(self, shape: torch.Tensor) -> dict[str, torch.Tensor]:
        """The shaped rest model; cached while the shape is not being optimised (stages 1-2)."""
        if shape.requires_grad:
            return self.model.rest(shape)
        key = getattr(self, "_rest_key", None)
        if key is None or key.shape != shape.shape or not torch.equal(key, shape):
            with torch.no_grad():
                rest = dict(self.model.rest(shape))
                if shape.shape[0] == 1:
                    rest["keypoint_basis"] = self._keypoint_basis(rest["rest_vertices"][0, self.kp_ids])
                self._rest_cache = rest
            self._rest_key = shape.detach().clone()
        return self._rest_cache

    def _keypoint_basis(self, kv: torch.Tensor) -> torch.Tensor:
        """(K, J, 4) ``A_kj`` of the class docstring from the (Sk, 3) rest vertices the regressor reads."""
        kvh = torch.cat([kv, kv.new_ones(kv.shape[0], 1)], -1)  # (Sk, 4)
        return torch.einsum("kvd,vj->kjd", self.regressor[:, :, None] * kvh[None], self.kp_weights)


def _skin(T34: torch.Tensor, weights: torch.Tensor, rest_v: torch.Tensor) -> torch.Tensor:
    """LBS of a vertex subset: T34 (B, J, 3, 4), weights (S, J) dense, rest_v (1 or B, S, 3)."""
    B, J = T34.shape[:2]
    blended = (weights @ T34.reshape(B, J, 12)).reshape(B, -1, 3, 4)
    return (blended[..., :3] @ rest_v.unsqueeze(-1)).squeeze(-1) + blended[..., 3]
