"""Retargeting a source motion onto Anny.

For each anchored Anny bone c driven by source joint j (see :mod:`morf.motion.joint_maps`):

1. Source world rotation relative to its rest pose, in Anny's axes:
   Q_j = A_w G_j A_r^T, with G_j from forward kinematics and A_w / A_r the axis changes of the
   source world and of its rest pose into Anny's Z-up world (they differ for AMASS: Z-up world,
   Y-up SMPL rest).
2. Body alignment C turns the source rest so it faces like Anny (from the hip line and the
   spine), so a source whose rest faces +X or -Z still comes out right.
3. Rest alignment per bone, R_c: the smallest rotation taking Anny's rest bone direction onto the
   source's (C-turned) rest bone direction, applied after the nearest anchored ancestor's
   alignment so twist carries down the chain. A T-pose source thus lifts Anny's A-pose arms.
4. Anny world rotation relative to its zero pose: M_c = Q_j C^T R_c, so that M_c d_anny = Q_j d_src.
   Unanchored spine/neck bones take a share of the rotation between their anchored neighbours
   (M_a (M_a^T M_b)^(i/k)); other unanchored bones follow their parent.
5. Anny "local-ref" deltas: D_c = M_parent^T M_c (root: D_0 = M_0); Anny composes
   M_c = M_parent D_c (checked against the body model by the tests).

The root translation is the source hip position scaled by Anny's leg length over the source's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import minimum_filter1d

from morf.errors import InputError
from morf.motion.joint_maps import SPREAD_BONES, JointMap
from morf.motion.name_matching import map_for
from morf.motion.skeleton import SourceMotion, forward_kinematics, to_z_up
from morf.motion.so3 import axis_rotation, fraction, frame_from, matrix_to_rotvec, rotvec_to_matrix, swing

if TYPE_CHECKING:
    from morf.motion.anny_rest import TargetRest


@dataclass(frozen=True)
class Retargeted:
    """Retargeted rotations before foot contact.

    Fields:
        rotvecs: (T, J, 3) Anny local-ref axis-angle per bone.
        transl: (T, 3) root translation, metres (source hips scaled, not yet on the ground).
        clearance: (T,) height of the source's lowest foot joint above the source's floor, scaled
            to Anny (0 while a foot is planted, > 0 in the air).
        source_positions: (T, Js, 3) source joints in Anny's world, scaled, same turn and shift
            as the root (for validation).
        scale: Anny leg length / source leg length.
        joint_map: the map used.
    """

    rotvecs: np.ndarray
    transl: np.ndarray
    clearance: np.ndarray
    source_positions: np.ndarray
    scale: float
    joint_map: JointMap


def _leg_length(rest: np.ndarray, idx, jm: JointMap) -> float:
    out = []
    for s in "LR":
        hip, knee, ankle = (jm.joint_for(f"{b}.{s}") for b in ("upperleg01", "lowerleg01", "foot"))
        if None in (hip, knee, ankle):
            raise InputError(f"joint map {jm.name!r} has no complete {s} leg")
        out.append(np.linalg.norm(rest[idx(knee)] - rest[idx(hip)]) + np.linalg.norm(rest[idx(ankle)] - rest[idx(knee)]))
    return float(np.mean(out))


def body_alignment(src_rest: np.ndarray, sidx, target: TargetRest, jm: JointMap) -> np.ndarray:
    """(3, 3) C turning the source rest (Anny axes) to face like Anny: hip line onto hip line, spine up."""
    l, r, up = sidx(jm.hips[0]), sidx(jm.hips[1]), sidx(jm.up)
    F_s = frame_from(src_rest[l] - src_rest[r], src_rest[up] - 0.5 * (src_rest[l] + src_rest[r]))
    h = target.heads
    al, ar, aup = target.index("upperleg01.L"), target.index("upperleg01.R"), target.index("neck01")
    F_a = frame_from(h[al] - h[ar], h[aup] - 0.5 * (h[al] + h[ar]))
    return F_a @ F_s.T


def retarget_rotations(source: SourceMotion, target: TargetRest, joint_map: JointMap | None = None) -> Retargeted:
    """Steps 1-5 of the module docstring for every frame (numpy, no body model evaluation)."""
    jm = joint_map or map_for(source.skeleton)
    sk = source.skeleton
    missing = sorted(j for j in jm.source_joints() if j not in sk.names)
    if missing:
        raise InputError(f"joint map {jm.name!r} needs joints this skeleton lacks: {', '.join(missing[:5])}")
    if jm.joint_for("root") is None:
        raise InputError(f"joint map {jm.name!r} has no root joint")
    sidx = sk.names.index
    G, X = forward_kinematics(source)
    A_w, A_r = to_z_up(source.up_axis), to_z_up(sk.up_axis)
    Q = A_w @ G @ A_r.T
    Xw = X @ A_w.T
    src_rest = sk.rest_positions() @ A_r.T
    C = body_alignment(src_rest, sidx, target, jm)

    names, parents, heads = target.names, target.parents, target.heads
    J, T = len(names), source.num_frames
    anchor = {target.index(a.bone): a for a in jm.anchors}
    anchored_parent = [_nearest(c, parents, anchor) for c in range(J)]

    align: dict[int, np.ndarray] = {}
    for c in sorted(anchor):
        a = anchor[c]
        base = align.get(anchored_parent[c], np.eye(3)) if c else np.eye(3)
        if c and a.bone_tip and a.joint_tip:
            d_anny = base @ (heads[target.index(a.bone_tip)] - heads[c])
            d_src = C @ (src_rest[sidx(a.joint_tip)] - src_rest[sidx(a.joint)])
            base = swing(d_anny, d_src) @ base
        align[c] = base

    M = np.empty((T, J, 3, 3))
    for c, a in anchor.items():
        M[:, c] = Q[:, sidx(a.joint)] @ (C.T @ align[c])
    spread = {target.index(b) for b in SPREAD_BONES if b in names}
    for c in range(1, J):
        if c in anchor:
            continue
        below = _anchored_below(c, parents, anchor, spread) if c in spread else None
        if below is not None:
            top = anchored_parent[c]
            k, i = _depth(below, top, parents), _depth(c, top, parents)
            M[:, c] = M[:, top] @ fraction(np.swapaxes(M[:, top], -1, -2) @ M[:, below], i / k)
        else:
            M[:, c] = M[:, parents[c]]

    D = np.empty_like(M)
    D[:, 0] = M[:, 0]
    par = np.asarray(parents[1:])
    D[:, 1:] = np.swapaxes(M[:, par], -1, -2) @ M[:, 1:]
    rotvecs = matrix_to_rotvec(D)

    scale = target.leg_length / _leg_length(src_rest, sidx, jm)
    root = sidx(jm.joint_for("root"))
    transl = scale * Xw[:, root]
    clearance = scale * source_clearance(Xw, src_rest, [sidx(j) for j in _foot_joints(jm)], source.fps)
    return Retargeted(rotvecs, transl, clearance, scale * Xw, float(scale), jm)


def _foot_joints(jm: JointMap) -> set[str]:
    feet = [a for a in jm.anchors if a.bone.startswith(("foot.", "toe"))]
    return {a.joint for a in feet} | {a.joint_tip for a in feet if a.joint_tip}


def source_clearance(X: np.ndarray, rest: np.ndarray, feet: list[int], fps: float, window_s: float = 1.0,
                     deadband: float = 0.02) -> np.ndarray:
    """(T,) height of the source's soles above its floor, metres (source scale): 0 while standing.

    Joint centres sit at different heights above the sole (ankle above toes), so each foot joint's
    height is lowered by its rest height above the lowest rest foot joint before taking the
    minimum over the feet. Mocap floors are not exact (and a dancer on tiptoe stands higher), so
    the floor is the lowest sole height within ``window_s`` around each frame: flight phases
    (jumps) keep their height, standing and walking get 0. Heights under ``deadband`` count as
    contact.
    """
    lift = rest[feet, 2] - rest[feet, 2].min()
    sole = (X[:, feet, 2] - lift).min(axis=1)
    floor = minimum_filter1d(sole, size=max(1, int(round(window_s * fps))) | 1, mode="nearest")
    return np.clip(sole - floor - deadband, 0.0, None)


def heading_turn(root: np.ndarray) -> np.ndarray:
    """(3, 3) the turn about Z that makes an Anny root rotation ``root`` (3, 3) face -Y."""
    fwd = root @ np.array([0.0, -1.0, 0.0])
    yaw = np.degrees(np.arctan2(fwd[0], -fwd[1]))  # angle from -Y towards +X
    return axis_rotation("z", -yaw)  # turns fwd back onto -Y


def turn_and_shift(r: Retargeted, face_forward: bool, center: bool) -> Retargeted:
    """Turn the whole motion about Z so frame 0 faces -Y, and shift it so frame 0's root is at x = y = 0."""
    rotvecs, transl, pos = r.rotvecs.copy(), r.transl.copy(), r.source_positions.copy()
    if face_forward:
        R0 = rotvec_to_matrix(rotvecs[:, 0])
        Rz = heading_turn(R0[0])
        rotvecs[:, 0] = matrix_to_rotvec(Rz @ R0)
        transl, pos = transl @ Rz.T, pos @ Rz.T
    if center:
        shift = np.array([transl[0, 0], transl[0, 1], 0.0])
        transl, pos = transl - shift, pos - shift
    return Retargeted(rotvecs, transl, r.clearance, pos, r.scale, r.joint_map)


def _nearest(c: int, parents, anchor) -> int | None:
    p = parents[c]
    while p >= 0 and p not in anchor:
        p = parents[p]
    return p if p >= 0 else None


def _anchored_below(c: int, parents, anchor, spread) -> int | None:
    """The first anchored bone below ``c`` along the spread chain (spine -> neck -> head)."""
    children = {}
    for b, p in enumerate(parents):
        children.setdefault(p, []).append(b)
    node = c
    while True:
        nxt = [b for b in children.get(node, []) if b in spread]
        if not nxt:
            return None
        node = nxt[0]
        if node in anchor:
            return node


def _depth(c: int, top: int, parents) -> int:
    n = 0
    while c != top:
        c = parents[c]
        n += 1
    return n
