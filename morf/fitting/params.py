"""What the fit optimises: per-frame root orientation, translation and body-bone rotations, and
the shape (6 phenotype values through a sigmoid, shared or per frame).

Fingers, toes, twist and helper bones stay at their rest rotation: a monocular video with
23 keypoints does not constrain them.
"""

from __future__ import annotations

import math

import torch

from morf.body.model import BodyPose, PoseMatrices
from morf.body.rotations import axis_angle_to_matrix, matrix_to_axis_angle

# Anny bones the fit rotates (the root is handled separately).
FIT_BONES = (
    "spine03", "spine02", "spine01", "neck01", "head",
    "clavicle.L", "upperarm01.L", "lowerarm01.L", "wrist.L",
    "clavicle.R", "upperarm01.R", "lowerarm01.R", "wrist.R",
    "upperleg01.L", "lowerleg01.L", "foot.L",
    "upperleg01.R", "lowerleg01.R", "foot.R",
)


def logit(p: torch.Tensor) -> torch.Tensor:
    p = p.clamp(1e-4, 1 - 1e-4)
    return torch.log(p) - torch.log1p(-p)


class FitParameters(torch.nn.Module):
    """Learnable fit parameters for N frames.

    Parameters:
        root_delta: (N, 3) axis-angle applied on top of the fixed initial root rotation
            ``root_init`` (N, 3, 3): optimising a small delta avoids the axis-angle wrap at pi
            while the person turns around.
        transl: (N, 3) root translation, metres.
        body: (N, len(FIT_BONES), 3) axis-angle per fitted bone.
        shape_logit: (1 or N, S) shape = sigmoid(shape_logit).
        offsets: (Vp,) clothing offsets of the silhouette proxy's vertices, metres along the rest
            normals, kept in [0, max] by projection after each step (empty without a proxy).
    """

    def __init__(self, num_frames: int, num_bones: int, bone_ids: list[int], root_init: torch.Tensor,
                 transl_init: torch.Tensor, shape_init: torch.Tensor, shared_shape: bool, num_offsets: int = 0):
        super().__init__()
        N = num_frames
        self.num_bones = num_bones
        self.register_buffer("bone_ids", torch.as_tensor(bone_ids, dtype=torch.long))
        self.register_buffer("root_init", root_init.detach().clone())
        self.root_delta = torch.nn.Parameter(torch.zeros(N, 3, dtype=root_init.dtype, device=root_init.device))
        self.transl = torch.nn.Parameter(transl_init.detach().clone())
        self.body = torch.nn.Parameter(torch.zeros(N, len(bone_ids), 3, dtype=root_init.dtype, device=root_init.device))
        shape = shape_init.detach().reshape(1, -1)
        if not shared_shape:
            shape = shape.expand(N, -1)
        self.shape_logit = torch.nn.Parameter(logit(shape).clone())
        self.offsets = torch.nn.Parameter(torch.zeros(num_offsets, dtype=root_init.dtype, device=root_init.device))

    @property
    def num_frames(self) -> int:
        return self.transl.shape[0]

    def root_matrix(self, idx: torch.Tensor | slice = slice(None)) -> torch.Tensor:
        """(n, 3, 3) root rotations of the selected frames."""
        return axis_angle_to_matrix(self.root_delta[idx]) @ self.root_init[idx]

    def shape(self, idx: torch.Tensor | slice = slice(None)) -> torch.Tensor:
        """(1, S) shared shape or (n, S) per-frame shapes, in [0, 1]."""
        s = torch.sigmoid(self.shape_logit)
        return s if s.shape[0] == 1 else s[idx]

    def pose(self, idx: torch.Tensor | slice = slice(None)) -> BodyPose:
        """Full (n, J, 3) model rotvecs + (n, 3) translation of the selected frames."""
        root = matrix_to_axis_angle(self.root_matrix(idx))
        body = self.body[idx]
        n = body.shape[0]
        rot = body.new_zeros(n, self.num_bones, 3)
        rot = rot.index_copy(1, self.bone_ids, body)
        rot = torch.cat([root[:, None], rot[:, 1:]], dim=1)
        return BodyPose(rotvecs=rot, transl=self.transl[idx])

    def pose_matrices(self, idx: torch.Tensor | slice = slice(None)) -> PoseMatrices:
        """:meth:`pose` with its rotations as (n, J, 3, 3) matrices (what the fit's forward
        kinematics consume), built without the root's matrix -> axis-angle round trip."""
        body = axis_angle_to_matrix(self.body[idx])
        n = body.shape[0]
        rot = torch.eye(3, dtype=body.dtype, device=body.device).repeat(n, self.num_bones, 1, 1)
        rot = rot.index_copy(1, self.bone_ids, body)
        rot = torch.cat([self.root_matrix(idx)[:, None], rot[:, 1:]], dim=1)
        return PoseMatrices(rotations=rot, transl=self.transl[idx])

    def load_state(self, rotvecs: torch.Tensor, transl: torch.Tensor, shape: torch.Tensor,
                   offsets: torch.Tensor | None = None) -> None:
        """Set parameters from saved full rotvecs (N, J, 3), transl (N, 3), shape (1 or N, S), offsets (Vp,)."""
        with torch.no_grad():
            self.root_init.copy_(axis_angle_to_matrix(rotvecs[:, 0]))
            self.root_delta.zero_()
            self.transl.copy_(transl)
            self.body.copy_(rotvecs[:, self.bone_ids])
            s = shape.reshape(-1, shape.shape[-1])
            if s.shape[0] != self.shape_logit.shape[0]:
                s = s.mean(0, keepdim=True).expand_as(self.shape_logit)
            self.shape_logit.copy_(logit(s))
            if offsets is not None and offsets.shape == self.offsets.shape:
                self.offsets.copy_(offsets)


def yaw_matrix(angle: torch.Tensor) -> torch.Tensor:
    """(..., 3, 3) rotation about the body's up axis (+Z) by ``angle`` radians."""
    z = torch.zeros_like(angle)
    return axis_angle_to_matrix(torch.stack([z, z, angle], -1))


def yaw_candidates(k: int, dtype=torch.float32) -> torch.Tensor:
    """(k,) yaw angles evenly spread over a full turn."""
    return torch.arange(k, dtype=dtype) * (2 * math.pi / k)
