"""Writing a :class:`~morf.motion.clip.MotionClip` as a BVH file (Blender, MotionBuilder, ...).

The hierarchy is Anny's bone tree in its zero pose (the A-pose every clip rotation is relative
to) for one body shape: one BVH joint per bone head, ``OFFSET`` = head minus parent head, in
metres, Y up, the person facing +Z with their left at +X (the usual BVH frame; Blender's importer
reads it with its defaults). Leaf bones end in an ``End Site`` along the bone. The root has six
channels (``Xposition Yposition Zposition`` then three rotations), every other joint three
rotations, all in one order (default ``Zrotation Yrotation Xrotation``: R = Rz @ Ry @ Rx, angles
in degrees, intrinsic as BVH means them).

Why the channels are Anny's own rotations: a clip's "local-ref" rotation D_c is the rotation of
bone c relative to its parent in world-aligned axes of the zero pose (M_c = M_parent D_c), which
is exactly a BVH joint's local rotation over a rest pose with identity joint frames. Only the axis
change A (Anny's Z up -> BVH's Y up) is applied: L_c = A D_c A^T. Root position = A (transl + h_0).
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass

import numpy as np
import torch
from scipy.spatial.transform import Rotation

from morf.io import atomic_write_text
from morf.motion.clip import MotionClip
from morf.motion.skeleton import to_z_up
from morf.motion.so3 import rotvec_to_matrix

ROTATION_ORDERS = ("ZYX", "ZXY", "YXZ", "YZX", "XYZ", "XZY")
END_SITE_MAX = 0.03  # metres: End Site length at most (a fingertip or toe tip, an eye's depth)

# Anny's world (Z up, facing -Y) -> BVH's (Y up, facing +Z): (x, y, z) -> (x, z, -y).
ANNY_TO_BVH = to_z_up("y").T


@dataclass(frozen=True)
class BvhSkeleton:
    """The BVH joint tree of one Anny body.

    Fields:
        names: J joint names (Anny bone names); parents: J parent indices, -1 for the root, in
            Anny's order (parents before children).
        offsets: (J, 3) float64 BVH ``OFFSET`` of each joint from its parent, metres, BVH axes
            (the root's row is its rest head position).
        end_sites: (J, 3) float64 ``End Site`` offset of each leaf joint (zeros for the others).
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    end_sites: np.ndarray

    @property
    def num_joints(self) -> int:
        return len(self.names)

    def children(self, j: int) -> list[int]:
        return [c for c, p in enumerate(self.parents) if p == j]

    def file_order(self) -> list[int]:
        """Joint indices in the order a BVH file lists them (depth first); channels follow it."""
        order, stack = [], [0]
        while stack:
            j = stack.pop()
            order.append(j)
            stack.extend(reversed(self.children(j)))
        return order


@torch.no_grad()
def anny_bvh_skeleton(model, shape: torch.Tensor | None = None) -> BvhSkeleton:
    """Anny's zero-pose bone tree for ``shape`` (1, 6) (default: its default shape) in BVH axes."""
    shape = model.default_shape() if shape is None else shape[:1]
    heads = model(model.zero_pose(1), shape).joints[0].double().cpu().numpy()
    bone_axes = model.rest(shape)["rest_bone_poses"][0, :, :3, 1].double().cpu().numpy()  # head -> tail
    parents = tuple(int(p) for p in model.bone_parents)
    offsets = heads.copy()
    for c, p in enumerate(parents):
        if p >= 0:
            offsets[c] = heads[c] - heads[p]
    ends = np.zeros_like(heads)
    leaves = [c for c in range(len(parents)) if c not in parents]
    for c in leaves:
        length = min(float(np.linalg.norm(offsets[c])), END_SITE_MAX) if parents[c] >= 0 else END_SITE_MAX
        ends[c] = bone_axes[c] / np.linalg.norm(bone_axes[c]) * max(length, 1e-3)
    return BvhSkeleton(tuple(model.bone_names), parents, offsets @ ANNY_TO_BVH.T, ends @ ANNY_TO_BVH.T)


def clip_channels(clip: MotionClip, skeleton: BvhSkeleton, order: str = "ZYX") -> np.ndarray:
    """The MOTION values of ``clip``: (T, 3 + 3 J) float64, root position (metres) and every
    joint's Euler angles (degrees, ``order``) in the skeleton's file order.

    Angles are unwrapped over time (no 360 degree jumps), which keyframe interpolation needs.
    """
    order = order.upper()
    if order not in ROTATION_ORDERS:
        raise ValueError(f"rotation order must be one of {ROTATION_ORDERS}, got {order!r}")
    T, J = clip.rotvecs.shape[:2]
    if J != skeleton.num_joints:
        raise ValueError(f"clip has {J} bones, skeleton {skeleton.num_joints}")
    A = ANNY_TO_BVH
    L = A @ rotvec_to_matrix(clip.rotvecs) @ A.T  # (T, J, 3, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # gimbal lock: the angles are still exact
        euler = Rotation.from_matrix(L.reshape(-1, 3, 3)).as_euler(order, degrees=True).reshape(T, J, 3)
    euler = np.unwrap(euler, period=360.0, axis=0)
    root_head = skeleton.offsets[0] @ A  # back in Anny's axes (A is orthonormal)
    position = (clip.transl.astype(np.float64) + root_head) @ A.T
    fo = skeleton.file_order()
    return np.concatenate([position, euler[:, fo].reshape(T, -1)], axis=1)


def bvh_text(clip: MotionClip, skeleton: BvhSkeleton, order: str = "ZYX") -> str:
    """The whole BVH file as text (see the module docstring)."""
    order = order.upper()
    rot = " ".join(f"{a}rotation" for a in order)
    lines = ["HIERARCHY"]

    def emit(j: int, depth: int) -> None:
        pad = "\t" * depth
        o = skeleton.offsets[j]
        lines.append(f"{pad}{'ROOT' if j == 0 else 'JOINT'} {skeleton.names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {o[0]:.6f} {o[1]:.6f} {o[2]:.6f}")
        lines.append(f"{pad}\tCHANNELS 6 Xposition Yposition Zposition {rot}" if j == 0 else f"{pad}\tCHANNELS 3 {rot}")
        kids = skeleton.children(j)
        for c in kids:
            emit(c, depth + 1)
        if not kids:
            e = skeleton.end_sites[j]
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {e[0]:.6f} {e[1]:.6f} {e[2]:.6f}",
                          f"{pad}\t}}"])
        lines.append(f"{pad}}}")

    emit(0, 0)
    values = clip_channels(clip, skeleton, order)
    lines += ["MOTION", f"Frames: {values.shape[0]}", f"Frame Time: {1.0 / clip.fps:.8f}"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in values]
    return "\n".join(lines) + "\n"


def write_clip_bvh(clip: MotionClip, path: str | os.PathLike, model, shape: torch.Tensor | None = None,
                   order: str = "ZYX") -> BvhSkeleton:
    """Write ``clip`` as BVH on Anny's skeleton for ``shape`` (1, 6) (atomic); returns the skeleton."""
    skeleton = anny_bvh_skeleton(model, shape)
    atomic_write_text(path, bvh_text(clip, skeleton, order))
    return skeleton
