"""Bone skinning matrices in plain numpy, so a player needs no torch.

Equivalent to Anny's "local-ref" forward kinematics (anny.utils.kinematics.forward_kinematic):
for bone c with parent p, rest pose P_c = [R_c | h_c], reference orientation U_c and delta
rotation D_c (world-aligned axes, about the bone's head):

    K_c = [U_p^T D_c U_c | U_p^T (q_c - q_p)],  q_c - q_p = A_p (h_c - h_p),  A_p = U_p R_p^T (A_0 = I)
    W_0 = [U_0^T D_0 U_0 | U_0^T d_0],          W_c = W_p K_c
    T_c = W_c P_c^-1                            (the skinning matrix)

Only the root carries a translation ``d_0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.records import length_of
from morf.rotations import rotvec_to_matrix_rodrigues  # noqa: F401  (imported from here too)


@dataclass(frozen=True)
class SkinningSkeleton:
    """An avatar's shaped Anny skeleton, ready for posing: pose in, bone skinning matrices out.

    Fields:
        names: (J,) str bone names; parents: (J,) int32, -1 for the root, parents before children.
        rest_rotations: (J, 3, 3) float64 R_c; rest_heads: (J, 3) float64 h_c.
        reference_rotations: (J, 3, 3) float64 U_c (Anny's reference bone orientations).
    """

    names: np.ndarray
    parents: np.ndarray
    rest_rotations: np.ndarray
    rest_heads: np.ndarray
    reference_rotations: np.ndarray

    num_bones = length_of("parents")

    def __post_init__(self):
        p = self.parents
        if p[0] != -1 or np.any(p[1:] >= np.arange(1, len(p))) or np.any(p[1:] < 0):
            raise ValueError("skeleton parents must list each parent before its children, root first")
        # Precompute what does not depend on the pose: per-level bone groups and the K translations.
        U, R, h = self.reference_rotations, self.rest_rotations, self.rest_heads
        A = np.einsum("jab,jcb->jac", U, R)
        A[0] = np.eye(3)
        pp = np.where(p < 0, 0, p)
        q_off = np.einsum("jab,jb->ja", A[pp], h - h[pp])
        object.__setattr__(self, "_k_transl", np.einsum("jba,jb->ja", U[pp], q_off))
        depth = np.zeros(len(p), np.int64)
        for c in range(1, len(p)):
            depth[c] = depth[p[c]] + 1
        object.__setattr__(self, "_levels", [np.nonzero(depth == d)[0] for d in range(1, depth.max() + 1)])

    def bone_transforms(self, rotvecs: np.ndarray, transl: np.ndarray) -> np.ndarray:
        """Skinning matrices of one pose.

        Args:
            rotvecs: (J, 3) axis-angle per bone ("local-ref", bone 0 = global orientation).
            transl: (3,) root translation.
        Returns:
            (J, 4, 4) float32 T_c: a rest vertex v maps to sum_c w_c T_c v.
        """
        rotvecs = np.asarray(rotvecs, np.float64)
        if rotvecs.shape != (self.num_bones, 3):
            raise ValueError(f"pose must be ({self.num_bones}, 3), got {rotvecs.shape}")
        U, R, h, p = self.reference_rotations, self.rest_rotations, self.rest_heads, self.parents
        D = rotvec_to_matrix_rodrigues(rotvecs)
        M = D @ U
        Upt = np.swapaxes(U[np.where(p < 0, 0, p)], 1, 2)
        K_rot = Upt @ M
        W_rot = np.empty_like(K_rot)
        W_t = np.empty((self.num_bones, 3))
        W_rot[0] = U[0].T @ M[0]
        W_t[0] = U[0].T @ np.asarray(transl, np.float64)
        for level in self._levels:
            par = p[level]
            W_rot[level] = W_rot[par] @ K_rot[level]
            W_t[level] = np.einsum("jab,jb->ja", W_rot[par], self._k_transl[level]) + W_t[par]
        T = np.zeros((self.num_bones, 4, 4))
        T_rot = W_rot @ np.swapaxes(R, 1, 2)
        T[:, :3, :3] = T_rot
        T[:, :3, 3] = W_t - np.einsum("jab,jb->ja", T_rot, h)
        T[:, 3, 3] = 1.0
        return T.astype(np.float32)

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {"bone_names": self.names.astype(str), "bone_parents": self.parents.astype(np.int32),
                "rest_rotations": self.rest_rotations, "rest_heads": self.rest_heads,
                "reference_rotations": self.reference_rotations}

    @staticmethod
    def from_arrays(a: dict[str, np.ndarray]) -> "SkinningSkeleton":
        return SkinningSkeleton(names=np.asarray(a["bone_names"]).astype(str),
                                parents=np.asarray(a["bone_parents"], np.int32),
                                rest_rotations=np.asarray(a["rest_rotations"], np.float64),
                                rest_heads=np.asarray(a["rest_heads"], np.float64),
                                reference_rotations=np.asarray(a["reference_rotations"], np.float64))


def skeleton_from_body_model(model, shape) -> SkinningSkeleton:
    """The shaped skeleton of an Anny body model (needs torch; used at export time only).

    Args:
        model: :class:`morf.body.anny_model.AnnyBodyModel`; shape: (1, 6) phenotype tensor.
    """
    import torch

    from morf.body.anny_model import reference_rotations

    with torch.no_grad():
        rest = model.rest(shape)["rest_bone_poses"][0].double().cpu().numpy()
    U = reference_rotations(model, shape, rest)
    return SkinningSkeleton(names=np.asarray(model.bone_names, dtype=str),
                            parents=np.asarray(model.bone_parents, np.int32), rest_rotations=rest[:, :3, :3].copy(),
                            rest_heads=rest[:, :3, 3].copy(), reference_rotations=U)
