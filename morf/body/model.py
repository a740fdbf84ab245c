"""The body model interface and the data it passes to later stages."""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class BodyPose:
    """Pose of a batch of frames.

    Fields:
        rotvecs: (B, J, 3) axis-angle per bone. Bone 0 is the root (global orientation);
            the meaning of the others is the model's (for Anny: rotations in world-aligned
            axes about each bone's head, composed after the parent's, "local-ref").
        transl: (B, 3) global translation in metres.
    """

    rotvecs: torch.Tensor
    transl: torch.Tensor

    @property
    def batch_size(self) -> int:
        return self.rotvecs.shape[0]


@dataclass(frozen=True)
class PoseMatrices:
    """A :class:`BodyPose` with its rotations as matrices (what forward kinematics consumes;
    the fit builds it directly and skips a matrix -> axis-angle -> matrix round trip).

    Fields:
        rotations: (B, J, 3, 3) per bone; transl: (B, 3) global translation in metres.
    """

    rotations: torch.Tensor
    transl: torch.Tensor


@dataclass(frozen=True)
class BodyOutput:
    """What a posed body gives to fitting, rasterization and playback.

    Fields:
        vertices: (B, V, 3) posed vertices (model topology), world metres.
        joints: (B, J, 3) bone head positions.
        bone_transforms: (B, J, 4, 4) skinning matrices (posed bone pose @ inverse rest bone pose):
            a rest vertex v maps to sum_j w_j * bone_transforms[j] @ v.
        rest_vertices: (B or 1, V, 3) shaped, unposed vertices.
        keypoints3d: (B, 23, 3) COCO-17 + 6 foot points (see morf.capture.keypoint_layout).
    """

    vertices: torch.Tensor
    joints: torch.Tensor
    bone_transforms: torch.Tensor
    rest_vertices: torch.Tensor
    keypoints3d: torch.Tensor


class BodyModel(torch.nn.Module):
    """A skinned body model. Subclasses implement :meth:`forward` and the topology fields.

    Attributes a subclass sets:
        bone_names: list[str], J names; bone 0 is the root.
        bone_parents: list[int], J parents (-1 for the root).
        shape_dim: int, number of shape parameters.
        faces: (F, 3) long triangles.
        uvs: (T, 2) texture coordinates in [0, 1] with v up (image row = 1 - v).
        face_uvs: (F, 3) long indices into ``uvs`` per face corner.
        skin_weights / skin_indices: (V, K) sparse skinning weights and bone ids.
    """

    bone_names: list[str]
    bone_parents: list[int]
    shape_dim: int

    def default_shape(self) -> torch.Tensor:
        """(1, S) a neutral shape to start optimisation from."""
        raise NotImplementedError

    def zero_pose(self, batch_size: int = 1) -> BodyPose:
        """The canonical pose (A-pose for Anny) at the origin."""
        J = len(self.bone_names)
        dev, dt = self.faces.device, self.dtype_
        return BodyPose(torch.zeros(batch_size, J, 3, device=dev, dtype=dt),
                        torch.zeros(batch_size, 3, device=dev, dtype=dt))

    @property
    def dtype_(self) -> torch.dtype:
        return torch.float32

    def bone_index(self, name: str) -> int:
        return self.bone_names.index(name)

    def forward(self, pose: BodyPose, shape: torch.Tensor) -> BodyOutput:  # pragma: no cover
        raise NotImplementedError
