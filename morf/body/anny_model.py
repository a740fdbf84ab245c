"""Anny (Apache-2.0 code, CC0 assets) behind the :class:`BodyModel` interface.

Anny is Z-up, faces -Y, the person's left is +X; the all-identity pose is an A-pose standing
with the pelvis at the origin (1.625 m tall at the default phenotype).
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading

import torch

from morf.body.anny_import import import_anny
from morf.body.kinematics import KinematicChain, forward_kinematics_local_ref
from morf.body.lbs import linear_blend_skinning
from morf.body.model import BodyModel, BodyOutput, BodyPose, PoseMatrices
from morf.body.rotations import axis_angle_to_matrix

_LOAD_LOCK = threading.Lock()

# Anny's phenotype values are interpolation weights in [0, 1]; exactly 0.5 sits on an
# interpolation corner with one-sided gradients, so start a little off it.
DEFAULT_PHENOTYPE = (0.52, 0.48, 0.52, 0.52, 0.52, 0.52)


@contextlib.contextmanager
def _quiet_stdio():
    """Silence warp's start-up banner and CUDA warning, which it prints at the C level.

    ``MORF_DEBUG=1`` keeps them.
    """
    if os.environ.get("MORF_DEBUG"):
        yield
        return
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def _rotation_matrices(pose: BodyPose | PoseMatrices) -> torch.Tensor:
    """(B, J, 3, 3) bone rotations of either pose form."""
    return pose.rotations if isinstance(pose, PoseMatrices) else axis_angle_to_matrix(pose.rotvecs)


class AnnyBodyModel(BodyModel):
    """Anny full-body model, float32, shape = 6 phenotype values in [0, 1]."""

    def __init__(self, topology: str = "anny"):
        super().__init__()
        with _LOAD_LOCK, _quiet_stdio():
            anny = import_anny()

            model = anny.Anny(topology=topology).to(torch.float32)
            regressor = anny.KeypointsRegressor.coco(model)
            # Anny's own forward pass skins with NVIDIA warp, which starts up (0.3 s) and prints
            # on its first call; this class skins with morf.body.lbs and never makes that call.
        self.anny = model
        self.bone_names = list(model.bone_labels)
        self.bone_parents = [int(p) for p in model.bone_parents]
        self.shape_dim = len(model.phenotype_labels)
        self.shape_names = list(model.phenotype_labels)
        self.register_buffer("faces", model.get_triangular_faces().long(), persistent=False)
        self.register_buffer("uvs", model.texture_coordinates.float(), persistent=False)
        self.register_buffer("face_uvs", model.face_texture_coordinate_indices.long(), persistent=False)
        self.register_buffer("skin_weights", model.vertex_bone_weights.float(), persistent=False)
        self.register_buffer("skin_indices", model.vertex_bone_indices.long(), persistent=False)
        dense = torch.zeros(model.template_vertices.shape[0], len(self.bone_names))
        dense.scatter_add_(1, self.skin_indices, self.skin_weights)
        self.register_buffer("dense_weights", dense, persistent=False)
        self.register_buffer("keypoint_regressor", regressor.regression_weights.float(), persistent=False)
        self._n_local = len(model.local_change_labels)
        # our batched-matmul kinematics where Anny uses the parameterization it implements
        self._chain = (KinematicChain.from_parents(model.bone_parents)
                       if model.pose_parameterization == "local-ref" else None)
        self._n_facial = len(model.facial_action_labels)

    @property
    def num_vertices(self) -> int:
        return self.dense_weights.shape[0]

    def default_shape(self) -> torch.Tensor:
        return torch.tensor([DEFAULT_PHENOTYPE], dtype=torch.float32, device=self.faces.device)

    def rest(self, shape: torch.Tensor) -> dict[str, torch.Tensor]:
        """Shaped rest model: ``rest_vertices`` (S, V, 3), ``rest_bone_poses`` (S, J, 4, 4)."""
        S = shape.shape[0]
        zeros = shape.new_zeros
        coeffs = self.anny._get_phenotype_blendshape_coefficients(
            shape, zeros(S, self._n_local), zeros(S, self._n_facial))
        return self.anny.get_rest_model(coeffs)

    @staticmethod
    def pose_to_deltas(pose: BodyPose | PoseMatrices) -> torch.Tensor:
        """(B, J, 4, 4) Anny "local-ref" delta transforms from the bone rotations + root translation."""
        R = _rotation_matrices(pose)
        B, J = R.shape[:2]
        top = torch.cat([R, R.new_zeros(B, J, 3, 1)], dim=-1)
        bottom = R.new_tensor([0, 0, 0, 1.0]).expand(B, J, 1, 4)
        T = torch.cat([top, bottom], dim=-2)
        trans = torch.zeros(B, J, 4, 4, dtype=T.dtype, device=T.device)
        trans[:, 0, :3, 3] = pose.transl
        return T + trans

    def bone_transforms(self, pose: BodyPose | PoseMatrices,
                        rest_bone_poses: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Skinning matrices and posed bone poses, both (B, J, 4, 4), for ``pose`` on a shaped rest
        skeleton ``rest_bone_poses`` (1 or B, J, 4, 4) from :meth:`rest`."""
        if self._chain is not None:
            return forward_kinematics_local_ref(self._chain, rest_bone_poses, _rotation_matrices(pose), pose.transl,
                                                self.anny.reference_bone_orientations)
        deltas = self.pose_to_deltas(pose)
        B = deltas.shape[0]
        if rest_bone_poses.shape[0] == 1 and B > 1:
            rest_bone_poses = rest_bone_poses.expand(B, -1, -1, -1)
        return self.anny.get_bone_transforms(deltas, rest_bone_poses)

    def forward(self, pose: BodyPose, shape: torch.Tensor) -> BodyOutput:
        """Pose a batch. ``shape`` is (1, 6) shared or (B, 6) per frame."""
        rest = self.rest(shape)
        B = pose.batch_size
        bone_transforms, bone_poses = self.bone_transforms(pose, rest["rest_bone_poses"])
        rest_v = rest["rest_vertices"]
        verts = linear_blend_skinning(rest_v.expand(B, -1, -1), self.dense_weights, bone_transforms)
        kp = torch.einsum("kv,bvc->bkc", self.keypoint_regressor, verts)
        return BodyOutput(vertices=verts, joints=bone_poses[..., :3, 3], bone_transforms=bone_transforms,
                          rest_vertices=rest_v, keypoints3d=kp)


def reference_rotations(model: AnnyBodyModel, shape, rest=None):
    """(J, 3, 3) float64 numpy: the frames a pose's bone rotations turn about ("local-ref"):
    Anny's reference bone orientations, else the rest rotations of the body ``shape`` (1, S)
    (``rest``: its (J, 4, 4) rest bone poses, when the caller has them)."""
    ref = model.anny.reference_bone_orientations
    if ref is not None:
        return ref.detach().double().cpu().numpy()
    if rest is None:
        with torch.no_grad():
            rest = model.rest(torch.as_tensor(shape, dtype=torch.float32).reshape(1, -1))["rest_bone_poses"][0]
    return torch.as_tensor(rest)[:, :3, :3].double().cpu().numpy()


def anny_cache_dir() -> str:
    return os.environ.get("ANNY_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "anny"))
