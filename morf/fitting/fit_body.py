"""The body as fitting sees it: only the vertices the losses need, skinned sparsely.

A full Anny forward pass skins 13.7k vertices against 104 bones with dense weights; fitting
needs the 23 keypoints (each a weighted mean of a few hundred vertices once the regressor's
negligible weights are pruned) and the silhouette proxy's vertices. Skinning those few
thousand vertices with Anny's sparse (at most 9 bones per vertex) weights makes a fitting step
many times cheaper than ``model(pose, shape)``, with the same result to well under a millimetre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.fitting.proxy_mesh import ProxyMesh


@dataclass(frozen=True)
class FitBodyOutput:
    """Fields:
        keypoints3d: (B, 23, 3) world keypoints (COCO-17 + feet).
        proxy_vertices: (B, Vp, 3) posed vertices of the silhouette proxy (empty if none).
    """

    keypoints3d: torch.Tensor
    proxy_vertices: torch.Tensor


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
    """Poses the keypoints and the proxy vertices of a body model from axis-angle parameters."""

    def __init__(self, model, proxy: ProxyMesh | None = None, regressor_mass: float = 0.999):
        super().__init__()
        self.model = model
        reg = prune_regressor(model.keypoint_regressor, regressor_mass)
        kp_ids = torch.nonzero(reg.abs().sum(0) > 0).squeeze(1)
        proxy_ids = torch.as_tensor(proxy.vertex_ids if proxy is not None else np.zeros(0, np.int64),
                                    device=kp_ids.device)
        ids = torch.cat([kp_ids, proxy_ids])
        self.num_keypoint_vertices = int(kp_ids.numel())
        self.register_buffer("vertex_ids", ids, persistent=False)
        self.register_buffer("regressor", reg[:, kp_ids].contiguous(), persistent=False)
        self.register_buffer("skin_weights", model.skin_weights[ids].contiguous(), persistent=False)
        self.register_buffer("skin_indices", model.skin_indices[ids].contiguous(), persistent=False)
        if proxy is not None:
            self.register_buffer("proxy_faces", torch.as_tensor(proxy.faces, device=ids.device), persistent=False)
        else:
            self.proxy_faces = None

    def forward(self, pose: BodyPose, shape: torch.Tensor) -> FitBodyOutput:
        """``pose``: (B, J, 3) rotvecs + (B, 3) transl; ``shape``: (1, S) shared or (B, S)."""
        model = self.model
        rest = model.rest(shape)
        rest_poses = rest["rest_bone_poses"]
        B = pose.batch_size
        if rest_poses.shape[0] == 1 and B > 1:
            rest_poses = rest_poses.expand(B, -1, -1, -1)
        T, _ = model.anny.get_bone_transforms(model.pose_to_deltas(pose), rest_poses)
        J = T.shape[1]
        T12 = T[:, :, :3, :].reshape(B, J, 12)
        # (B, S, 9, 12) gathered per vertex, blended by its sparse weights
        blended = (T12[:, self.skin_indices] * self.skin_weights[None, :, :, None]).sum(2).reshape(B, -1, 3, 4)
        rest_v = rest["rest_vertices"][:, self.vertex_ids]
        if rest_v.shape[0] == 1 and B > 1:
            rest_v = rest_v.expand(B, -1, -1)
        verts = (blended[..., :3] @ rest_v.unsqueeze(-1)).squeeze(-1) + blended[..., 3]
        n = self.num_keypoint_vertices
        kp = torch.einsum("kv,bvc->bkc", self.regressor, verts[:, :n])
        return FitBodyOutput(keypoints3d=kp, proxy_vertices=verts[:, n:])
