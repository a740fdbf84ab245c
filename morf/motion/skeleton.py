"""Source skeletons (BVH, SMPL family) and their forward kinematics, in numpy.

A source motion is kept in its own conventions (rest pose, up axis, joint names) until
retargeting; only lengths are converted to metres on reading.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.motion.so3 import axis_rotation


@dataclass(frozen=True)
class SourceSkeleton:
    """The skeleton of a source motion (BVH, SMPL family): a joint hierarchy in its rest pose
    (all joint rotations identity).

    Fields:
        names: J joint names (BVH end sites are joints named ``<parent>_end``).
        parents: J parent indices, -1 for the root, every parent before its children.
        offsets: (J, 3) float64 rest offset of each joint from its parent, metres
            (the root's row is its rest position).
        up_axis: "y" or "z", the up axis of the rest pose.
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    up_axis: str = "y"

    @property
    def num_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def rest_positions(self) -> np.ndarray:
        """(J, 3) joint positions in the rest pose, root at its rest offset."""
        pos = np.zeros((self.num_joints, 3))
        for j, p in enumerate(self.parents):
            pos[j] = self.offsets[j] if p < 0 else pos[p] + self.offsets[j]
        return pos

    def children(self, j: int) -> list[int]:
        return [c for c, p in enumerate(self.parents) if p == j]

    def ancestors(self, j: int) -> list[int]:
        """Indices from ``j``'s parent up to the root."""
        out = []
        while self.parents[j] >= 0:
            j = self.parents[j]
            out.append(j)
        return out


@dataclass(frozen=True)
class SourceMotion:
    """A motion on its own skeleton.

    Fields:
        skeleton: the rest skeleton (its up axis may differ from the world's, as in AMASS).
        local_rotations: (T, J, 3, 3) float64 rotation of each joint relative to its parent,
            in the parent's frame; identity everywhere = the rest pose.
        root_positions: (T, 3) float64 world position of the root joint, metres.
        fps: frames per second.
        up_axis: "y" or "z", the up axis of the world the rotations map into.
        name: short clip name; source: where it came from (file path, format).
        kind: "bvh", "smplh" or "smplx" (selects the joint map).
        channel_orders: per joint, the rotation order read from the file ("ZYX", "" for none;
            empty tuple when the format has no such thing).
        notes: what the reader read but could not use (a jaw rotation the body has no bone for),
            one sentence each, for the user.
    """

    skeleton: SourceSkeleton
    local_rotations: np.ndarray
    root_positions: np.ndarray
    fps: float
    up_axis: str = "y"
    name: str = ""
    source: str = ""
    kind: str = "bvh"
    channel_orders: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def num_frames(self) -> int:
        return int(self.local_rotations.shape[0])


def forward_kinematics(motion: SourceMotion) -> tuple[np.ndarray, np.ndarray]:
    """World rotations (T, J, 3, 3) and joint positions (T, J, 3) of every frame.

    Joint c of parent p: G_c = G_p L_c and x_c = x_p + G_p offset_c (offsets in metres).
    """
    sk = motion.skeleton
    L = motion.local_rotations
    T, J = L.shape[:2]
    G = np.empty_like(L)
    X = np.empty((T, J, 3))
    for j, p in enumerate(sk.parents):
        if p < 0:
            G[:, j] = L[:, j]
            X[:, j] = motion.root_positions
        else:
            G[:, j] = G[:, p] @ L[:, j]
            X[:, j] = X[:, p] + G[:, p] @ sk.offsets[j]
    return G, X


def to_z_up(up_axis: str) -> np.ndarray:
    """(3, 3) axis change into Anny's world: Z up, the person's forward -Y, left +X.

    A Y-up skeleton facing +Z with its left at +X (BVH, SMPL) maps by a +90 degree turn about X
    (y -> z, z -> -y); a Z-up one is kept as it is.
    """
    if up_axis == "y":
        return axis_rotation("x", 90.0)
    if up_axis == "z":
        return np.eye(3)
    raise ValueError(f"up axis must be 'y' or 'z', got {up_axis!r}")


# Length units found in motion files, in metres. The CMU "ASF" unit is 1/0.45 inch
# (its ASF files declare ``length 0.45``), which is what CMU BVH conversions keep.
UNITS = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001, "inch": 0.0254, "cmu": 0.0254 / 0.45, "foot": 0.3048}

# Head-joint height above the feet of an adult skeleton, metres: what unit detection aims for.
TYPICAL_HEAD_HEIGHT = 1.5


def detect_unit(rest_positions: np.ndarray, up_axis: str) -> tuple[str, float]:
    """(unit name, metres per unit) that makes a rest skeleton's height most human.

    The height is the extent of the rest joints along ``up_axis``; the unit whose scaled
    height is closest to :data:`TYPICAL_HEAD_HEIGHT` on a log scale wins.
    """
    axis = "xyz".index(up_axis)
    height = float(np.ptp(rest_positions[:, axis]))
    if not np.isfinite(height) or height <= 0:
        return "m", 1.0
    name = min(UNITS, key=lambda u: abs(np.log(height * UNITS[u] / TYPICAL_HEAD_HEIGHT)))
    return name, UNITS[name]
