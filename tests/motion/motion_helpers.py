"""Small synthetic skeletons and files for the motion tests."""

from __future__ import annotations

import numpy as np

from morf.motion.skeleton import SourceMotion, SourceSkeleton

# A Mixamo-like T-pose skeleton, Y up, facing +Z, the person's left at +X, in centimetres.
# (name, parent, offset)
TPOSE_JOINTS = (
    ("Hips", None, (0, 95, 0)),
    ("Spine", "Hips", (0, 10, 0)), ("Spine1", "Spine", (0, 12, 0)), ("Spine2", "Spine1", (0, 14, 0)),
    ("Neck", "Spine2", (0, 16, 0)), ("Head", "Neck", (0, 10, 2)), ("HeadTop_End", "Head", (0, 18, 0)),
    ("LeftShoulder", "Spine2", (6, 12, 0)), ("LeftArm", "LeftShoulder", (12, 0, 0)),
    ("LeftForeArm", "LeftArm", (27, 0, 0)), ("LeftHand", "LeftForeArm", (25, 0, 0)),
    ("LeftHandMiddle1", "LeftHand", (9, 0, 0)), ("LeftHandMiddle_End", "LeftHandMiddle1", (8, 0, 0)),
    ("RightShoulder", "Spine2", (-6, 12, 0)), ("RightArm", "RightShoulder", (-12, 0, 0)),
    ("RightForeArm", "RightArm", (-27, 0, 0)), ("RightHand", "RightForeArm", (-25, 0, 0)),
    ("RightHandMiddle1", "RightHand", (-9, 0, 0)), ("RightHandMiddle_End", "RightHandMiddle1", (-8, 0, 0)),
    ("LeftUpLeg", "Hips", (9, -5, 0)), ("LeftLeg", "LeftUpLeg", (0, -42, 0)), ("LeftFoot", "LeftLeg", (0, -40, 0)),
    ("LeftToeBase", "LeftFoot", (0, -7, 12)), ("LeftToe_End", "LeftToeBase", (0, 0, 7)),
    ("RightUpLeg", "Hips", (-9, -5, 0)), ("RightLeg", "RightUpLeg", (0, -42, 0)), ("RightFoot", "RightLeg", (0, -40, 0)),
    ("RightToeBase", "RightFoot", (0, -7, 12)), ("RightToe_End", "RightToeBase", (0, 0, 7)),
)


def tpose_skeleton(scale: float = 0.01) -> SourceSkeleton:
    names = tuple(n for n, _, _ in TPOSE_JOINTS)
    parents = tuple(-1 if p is None else names.index(p) for _, p, _ in TPOSE_JOINTS)
    offsets = np.array([o for _, _, o in TPOSE_JOINTS], dtype=np.float64) * scale
    return SourceSkeleton(names, parents, offsets, "y")


def tpose_motion(frames: int = 2, fps: float = 30.0) -> SourceMotion:
    """The T-pose skeleton standing still (identity rotations), hips 0.95 m up."""
    sk = tpose_skeleton()
    local = np.broadcast_to(np.eye(3), (frames, sk.num_joints, 3, 3)).copy()
    root = np.broadcast_to(sk.offsets[0], (frames, 3)).copy()
    return SourceMotion(sk, local, root, fps, up_axis="y", name="tpose", source="test", kind="bvh")


def write_bvh(path, scale: float = 1.0, frames: int = 3, fps: float = 30.0, z_up: bool = False,
              child_order: str = "ZXY", values: np.ndarray | None = None) -> None:
    """The T-pose skeleton as a BVH file (offsets in cm times ``scale``); root XYZ position + ZYX rotation,
    other joints ``child_order``; one 6-channel child (Spine) to exercise position channels."""
    sk = tpose_skeleton(scale=1.0)
    off = sk.offsets * scale
    if z_up:  # y up -> z up (x, y, z) -> (x, -z, y)
        off = np.stack([off[:, 0], -off[:, 2], off[:, 1]], axis=1)
    children = {i: [c for c, p in enumerate(sk.parents) if p == i] for i in range(sk.num_joints)}
    lines = ["HIERARCHY"]
    n_channels = []

    def emit(j, depth):
        pad = "  " * depth
        name = sk.names[j]
        if name.endswith("_End"):
            lines.append(f"{pad}End Site")
            lines.append(f"{pad}{{")
            lines.append(f"{pad}  OFFSET {off[j, 0]:.5f} {off[j, 1]:.5f} {off[j, 2]:.5f}")
            lines.append(f"{pad}}}")
            return
        lines.append(f"{pad}{'ROOT' if j == 0 else 'JOINT'} {name}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {off[j, 0]:.5f} {off[j, 1]:.5f} {off[j, 2]:.5f}")
        if j == 0:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation")
            n_channels.append(6)
        elif name == "Spine":
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation")
            n_channels.append(6)
        else:
            lines.append(f"{pad}  CHANNELS 3 " + " ".join(f"{a}rotation" for a in child_order))
            n_channels.append(3)
        for c in children[j]:
            emit(c, depth + 1)
        lines.append(f"{pad}}}")

    emit(0, 0)
    total = sum(n_channels)
    if values is None:
        values = np.zeros((frames, total))
        values[:, 1 if not z_up else 2] = 95.0 * scale  # hips height
        spine_col = 6  # Spine's channels follow the root's (first child in file order)
        values[:, spine_col:spine_col + 3] = off[1]
    lines += ["MOTION", f"Frames: {values.shape[0]}", f"Frame Time: {1.0 / fps:.7f}"]
    lines += [" ".join(f"{v:.5f}" for v in row) for row in values]
    path.write_text("\n".join(lines) + "\n")
    return total
