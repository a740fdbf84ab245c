"""The body's skeleton as glTF joint nodes: axes, bind pose, inverse bind matrices, poses, weights.

glTF skins a vertex as ``sum_j w_j G_j B_j v`` where ``G_j`` is joint j's global node transform and
``B_j`` its inverse bind matrix. Our skinning matrices are ``T_c = W_c P_c^-1``
(:mod:`morf.export.skeleton`: ``W_c`` the posed bone frame, ``P_c`` the rest bone frame, both
global), so joint nodes carry the bone frames themselves: in the bind pose their globals are
``P_c`` (mesh vertices are the shaped rest vertices, ``B_c = P_c^-1``); in a pose ``W_c``. A node's
local transform is ``G_parent^-1 G_c``; for every bone but the root its translation is the same in
all poses (the bone offset), so a pose is one rotation per joint plus the root's translation. (The
root's children keep their bind-pose offsets only where the root's reference and rest orientations
agree, as on Anny; :func:`morf.export.gltf_animation.moving_joints` checks.)

Axes: glTF is Y up with the asset facing +Z; Anny is Z up facing -Y (left = +X in both), so
every position and frame is mapped by the rotation :data:`Y_UP` (x, y, z) -> (x, z, -y).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from morf.export.skeleton import SkinningSkeleton
from morf.records import length_of

# Anny world (Z up, faces -Y) -> glTF world (Y up, faces +Z)
Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


@dataclass(frozen=True)
class GltfRig:
    """Joint nodes of a skin, in glTF axes.

    Fields:
        names: (J,) str joint names; parents: (J,) int32, -1 for the root, parents first.
        rotations: (J, 4) float64 bind-pose local rotations, unit quaternions (x, y, z, w).
        translations: (J, 3) float64 bind-pose local translations (metres).
        inverse_bind: (J, 4, 4) float64 inverse of each joint's global bind transform (row-major).
    """

    names: np.ndarray
    parents: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray
    inverse_bind: np.ndarray

    num_joints = length_of("parents")


def to_gltf_axes(frames: np.ndarray) -> np.ndarray:
    """(..., 4, 4) rigid transforms in Anny's world -> the same transforms in glTF's world."""
    C = np.eye(4)
    C[:3, :3] = Y_UP
    return C @ np.asarray(frames, np.float64) @ C.T


def rest_frames(skeleton: SkinningSkeleton) -> np.ndarray:
    """(J, 4, 4) float64 global rest bone frames ``P_c = [R_c | h_c]`` (Anny axes)."""
    P = np.zeros((skeleton.num_bones, 4, 4))
    P[:, :3, :3] = skeleton.rest_rotations
    P[:, :3, 3] = skeleton.rest_heads
    P[:, 3, 3] = 1.0
    return P


def posed_bone_frames(skeleton: SkinningSkeleton, rotvecs: np.ndarray, transl: np.ndarray) -> np.ndarray:
    """(J, 4, 4) float64 global posed bone frames ``W_c = T_c P_c`` (Anny axes) of one pose.

    Args:
        rotvecs: (J, 3) axis-angle per bone (Anny "local-ref"); transl: (3,) root translation.
    """
    T = skeleton.bone_transforms(rotvecs, transl).astype(np.float64)
    return T @ rest_frames(skeleton)


def local_transforms(frames: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """(J, 4, 4) global frames -> (J, 4, 4) node-local transforms ``G_parent^-1 G_c``."""
    out = np.array(frames, np.float64)
    child = np.nonzero(parents >= 0)[0]
    out[child] = np.linalg.inv(frames[parents[child]]) @ frames[child]
    return out


def global_transforms(rotations: np.ndarray, translations: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """(J, 4, 4) globals from node-local TRS (no scale): quaternions (J, 4) xyzw, translations (J, 3)."""
    local = np.zeros((len(parents), 4, 4))
    local[:, :3, :3] = Rotation.from_quat(rotations).as_matrix()
    local[:, :3, 3] = translations
    local[:, 3, 3] = 1.0
    out = np.empty_like(local)
    for j, p in enumerate(parents):
        out[j] = local[j] if p < 0 else out[p] @ local[j]
    return out


def trs_of(local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(J, 4, 4) rigid local transforms -> quaternions (J, 4) xyzw with w >= 0, translations (J, 3)."""
    q = Rotation.from_matrix(local[:, :3, :3]).as_quat()
    q *= np.where(q[:, 3:] < 0, -1.0, 1.0)
    return q, local[:, :3, 3].copy()


def gltf_rig(skeleton: SkinningSkeleton) -> GltfRig:
    """The skin's joints in their bind pose (the shaped rest pose of ``skeleton``)."""
    parents = skeleton.parents.astype(np.int32)
    q, t = trs_of(local_transforms(to_gltf_axes(rest_frames(skeleton)), parents))
    # Invert the globals the file's own TRS gives (not P directly), so that a reader composing the
    # nodes gets exactly the identity skin in the bind pose.
    inverse_bind = np.linalg.inv(global_transforms(q, t, parents))
    return GltfRig(names=np.asarray(skeleton.names, str), parents=parents, rotations=q, translations=t,
                   inverse_bind=inverse_bind)


def pose_nodes(skeleton: SkinningSkeleton, rotvecs: np.ndarray, transl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Node-local TRS (glTF axes) that pose the skin as :meth:`SkinningSkeleton.bone_transforms` does.

    Args:
        rotvecs: (J, 3) axis-angle per bone (Anny "local-ref"); transl: (3,) root translation (Anny axes).
    Returns:
        rotations (J, 4) xyzw quaternions, translations (J, 3) (all but the root's are the same in
        every pose).
    """
    local = local_transforms(to_gltf_axes(posed_bone_frames(skeleton, rotvecs, transl)), skeleton.parents)
    return trs_of(local)


def top_influences(weights: np.ndarray, k: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` largest skinning weights per vertex, renormalised to sum to 1.

    Args:
        weights: (V, J) dense skinning weights.
    Returns:
        joints (V, k) uint8 (J <= 256) or uint16, weights (V, k) float32; unused slots have
        weight 0 and joint 0. The float32 sums are 1 to rounding: the residual of the
        renormalisation is put on each vertex's largest weight.
    """
    w = np.asarray(weights, np.float64)
    idx = np.argsort(-w, axis=1, kind="stable")[:, :k]
    vals = np.take_along_axis(w, idx, axis=1)
    vals = vals / np.clip(vals.sum(1, keepdims=True), 1e-12, None)
    idx = np.where(vals > 0, idx, 0)
    out = vals.astype(np.float32)
    out[:, 0] += (1.0 - out.astype(np.float64).sum(1)).astype(np.float32)
    dtype = np.uint8 if w.shape[1] <= 256 else np.uint16
    return idx.astype(dtype), out
