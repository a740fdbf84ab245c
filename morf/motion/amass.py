"""AMASS motion files (.npz): SMPL-H (``poses`` (T, 156)) or SMPL-X (``poses`` (T, 165), or the
split ``root_orient`` / ``pose_body`` (+ ``pose_hand``, ``pose_jaw``, ``pose_eye``) keys),
``trans`` (T, 3), ``mocap_framerate`` or ``mocap_frame_rate``, ``gender`` as str or bytes,
``betas``. Stored Z-up. Other arrays (``dmpls``, ``marker_data``, SMPL-X marker metadata, which
may be pickled and is never loaded) are ignored. Also the SMPL skeleton shared with
:mod:`morf.motion.smpl` and :mod:`morf.motion.smpl_params`.

The SMPL body models themselves are licensed and are not needed: retargeting uses only rest bone
directions and leg length, taken from the approximate neutral rest joints below.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.io import load_npz
from morf.motion.checks import check_duration, check_fps, check_rotvecs, check_translations, numbers
from morf.motion.skeleton import SourceMotion, SourceSkeleton
from morf.motion.smpl_hands import detail_joints
from morf.motion.so3 import rotvec_to_matrix

SMPL_BODY_JOINTS = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
    "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
)
SMPL_BODY_PARENTS = (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19)

# Segment ends with no rotation of their own in AMASS: the middle-finger base, toe tips, head top.
SMPL_END_JOINTS = (("left_hand", 20), ("right_hand", 21), ("left_foot_end", 10), ("right_foot_end", 11),
                   ("head_end", 15))

# Neutral SMPL rest (T-pose) joint positions, metres, Y up, facing +Z, left +X; rounded to about
# a centimetre and made left/right symmetric. Only directions and the leg length are used.
SMPL_REST = np.array([
    [0.000, -0.223, 0.028], [0.068, -0.313, 0.020], [-0.068, -0.313, 0.020], [0.000, -0.110, 0.000],
    [0.105, -0.690, 0.010], [-0.105, -0.690, 0.010], [0.000, 0.025, 0.030], [0.085, -1.095, -0.030],
    [-0.085, -1.095, -0.030], [0.000, 0.080, 0.030], [0.120, -1.150, 0.120], [-0.120, -1.150, 0.120],
    [0.000, 0.290, -0.015], [0.075, 0.200, -0.010], [-0.075, 0.200, -0.010], [0.000, 0.355, 0.045],
    [0.170, 0.225, -0.020], [-0.170, 0.225, -0.020], [0.430, 0.215, -0.040], [-0.430, 0.215, -0.040],
    [0.690, 0.225, -0.045], [-0.690, 0.225, -0.045],
    # ends
    [0.775, 0.215, -0.050], [-0.775, 0.215, -0.050], [0.125, -1.165, 0.190], [-0.125, -1.165, 0.190],
    [0.000, 0.560, 0.030],
])


def smpl_skeleton(detail: bool = False) -> SourceSkeleton:
    """The 22 SMPL body joints plus 5 end points, rest pose in metres, Y up; with ``detail`` also
    both hands' 30 finger joints and the two eyes (:func:`morf.motion.smpl_hands.detail_joints`)."""
    names = SMPL_BODY_JOINTS + tuple(n for n, _ in SMPL_END_JOINTS)
    parents = SMPL_BODY_PARENTS + tuple(p for _, p in SMPL_END_JOINTS)
    offsets = SMPL_REST.copy()
    for j, p in enumerate(parents):
        if p >= 0:
            offsets[j] = SMPL_REST[j] - SMPL_REST[p]
    if detail:
        wrists = {"left": names.index("left_wrist"), "right": names.index("right_wrist")}
        more, more_parents, more_offsets = detail_joints(wrists, names.index("head"), len(names))
        names, parents, offsets = names + more, parents + more_parents, np.concatenate([offsets, more_offsets])
    return SourceSkeleton(names, parents, offsets, "y")


# Keys under which motion .npz files store their frame rate (AMASS SMPL-H, AMASS SMPL-X, ours).
FPS_KEYS = ("mocap_framerate", "mocap_frame_rate", "fps")


def text_value(value: np.ndarray) -> str:
    """A string stored in an .npz as text (``np.array('male')``) or bytes (``np.array(b'male')``)."""
    v = value.item() if value.ndim == 0 else value.reshape(-1)[0]
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


def stored_fps(arrays: dict[str, np.ndarray], path: str | Path) -> float | None:
    """The frame rate a motion .npz stores (AMASS ``mocap_framerate`` / ``mocap_frame_rate``, or
    ``fps``), or None when it stores none. InputError for a rate that is not a positive number."""
    key = next((k for k in FPS_KEYS if k in arrays), None)
    if key is None:
        return None
    value = np.asarray(arrays[key])
    if value.size == 0 or value.dtype.kind not in "iuf":
        raise InputError(f"{path}: '{key}' is not a frame rate")
    return check_fps(value.reshape(-1)[0], str(path), f"'{key}'")


def smpl_source_motion(body: np.ndarray, trans: np.ndarray, fps: float, up_axis: str, path: Path, source: str,
                       kind: str, hands: np.ndarray | None = None, eyes: np.ndarray | None = None,
                       notes: tuple[str, ...] = ()) -> SourceMotion:
    """A :class:`SourceMotion` on the SMPL body joints, and on the fingers and eyes where given.

    Args:
        body: (T, 66) axis-angle of the 22 body joints (root first), SMPL order.
        trans: (T, 3) SMPL translation, metres (the pelvis lands at trans + its rest position).
        up_axis: "y" or "z", the world's up axis.
        hands: (T, 30, 3) axis-angle of both hands' joints (left hand first, MANO order), or None.
        eyes: (T, 2, 3) axis-angle of the left and right eye, or None.
        notes: what the reader left out, for the user (:attr:`SourceMotion.notes`).

    Hands and eyes that never leave their rest pose change nothing; they are then left out, so
    such a file retargets exactly as a body-only one.
    """
    T = body.shape[0]
    if T == 0:
        raise InputError(f"{path}: no frames")
    if trans.shape != (T, 3):
        raise InputError(f"{path}: translation has shape {trans.shape}; expected ({T}, 3)")
    check_rotvecs(body, str(path), "the body rotations")  # the readers checked their own arrays by name
    check_translations(trans, str(path), "the translations")
    check_duration(T, fps, str(path))
    parts = {"hands": (hands, 30), "eyes": (eyes, 2)}
    for what, (a, n) in parts.items():
        if a is not None:
            if a.shape != (T, n, 3):
                raise InputError(f"{path}: {what} rotations have shape {a.shape}; expected ({T}, {n}, 3)")
            check_rotvecs(a, str(path), f"the {what} rotations")
    detail = any(a is not None and np.any(a) for a, _ in parts.values())
    sk = smpl_skeleton(detail)
    local = np.broadcast_to(np.eye(3), (T, sk.num_joints, 3, 3)).copy()
    local[:, :22] = rotvec_to_matrix(body.reshape(T, 22, 3))
    if detail:
        first = sk.index("left_index1")
        for a, start, n in ((hands, first, 30), (eyes, sk.index("left_eye"), 2)):
            if a is not None:
                local[:, start:start + n] = rotvec_to_matrix(a)
    # SMPL rotates the body about the rest pelvis and then adds trans: the pelvis lands at trans + J_pelvis.
    root = trans + SMPL_REST[0]
    return SourceMotion(sk, local, root, fps, up_axis=up_axis, name=path.stem, source=source, kind=kind,
                        notes=tuple(notes))


def face_notes(jaw: np.ndarray | None, expression: np.ndarray | None = None) -> tuple[str, ...]:
    """What a SMPL-X file's face holds that Anny cannot show: a jaw rotation (Anny has no jaw
    bone) or facial expression coefficients; nothing when they stay at zero."""
    out = []
    if jaw is not None and np.any(jaw):
        out.append("the jaw rotation is not used: the body model has no jaw bone")
    if expression is not None and np.any(expression):
        out.append("the facial expression is not used: the body model has no expression shapes")
    return tuple(out)


def read_amass(path: str | Path, arrays: dict[str, np.ndarray] | None = None, fps: float | None = None) -> SourceMotion:
    """Read an AMASS .npz (SMPL-H or SMPL-X) into a Z-up :class:`SourceMotion` on the SMPL body
    joints, the fingers and (SMPL-X) the eyes (:mod:`morf.motion.smpl_hands`).

    ``fps`` is used only when the file stores no frame rate (default then 30). A SMPL-X jaw
    rotation is not used (Anny has no jaw); the motion's notes say so when it moves.
    Raises:
        InputError: missing keys or wrong shapes.
    """
    path = Path(path)
    if arrays is None:
        arrays = load_npz(path, error=InputError, skip_pickled=True)
    jaw = eyes = None
    if "poses" in arrays:
        poses = numbers(arrays, "poses", str(path))
        if poses.ndim != 2 or poses.shape[1] not in (156, 165):
            raise InputError(f"{path}: 'poses' has shape {poses.shape}; expected (T, 156) SMPL-H, (T, 165) SMPL-X "
                             "or (T, 72) SMPL")
        kind = {156: "smplh", 165: "smplx"}[poses.shape[1]]
        check_rotvecs(poses, str(path), "'poses'")
        T = poses.shape[0]
        body = poses[:, :66]
        if kind == "smplh":  # 22 body joints, 15 + 15 hand joints
            hands = poses[:, 66:].reshape(T, 30, 3)
        else:  # 22 body joints, jaw, two eyes, 15 + 15 hand joints
            jaw, eyes, hands = poses[:, 66:69], poses[:, 69:75].reshape(T, 2, 3), poses[:, 75:].reshape(T, 30, 3)
    elif "root_orient" in arrays and "pose_body" in arrays:
        parts = [numbers(arrays, k, str(path)) for k in ("root_orient", "pose_body")]
        if [a.shape[1:] for a in parts] != [(3,), (63,)] or parts[0].shape[0] != parts[1].shape[0]:
            raise InputError(f"{path}: 'root_orient' {parts[0].shape} and 'pose_body' {parts[1].shape}; "
                             "expected (T, 3) and (T, 63)")
        for key, a in zip(("root_orient", "pose_body"), parts):
            check_rotvecs(a, str(path), f"'{key}'")
        body = np.concatenate(parts, axis=1)
        T = body.shape[0]
        hands, jaw, eyes = (_optional_part(arrays, key, T, n, path)
                            for key, n in (("pose_hand", 30), ("pose_jaw", 1), ("pose_eye", 2)))
        kind = "smplx"
    else:
        raise InputError(f"{path}: not an AMASS motion (no 'poses' or 'root_orient'/'pose_body' arrays)")
    trans = numbers(arrays, "trans", str(path), np.zeros((T, 3)))
    if trans.shape == (T, 3):
        check_translations(trans, str(path), "'trans'")
    fps = stored_fps(arrays, path) or fps or 30.0
    gender = text_value(np.asarray(arrays["gender"])) if "gender" in arrays else "neutral"
    return smpl_source_motion(body, trans, fps, "z", path, f"amass:{path.name} ({kind}, {gender})", kind,
                              hands, eyes, face_notes(jaw))


def _optional_part(arrays: dict[str, np.ndarray], key: str, T: int, joints: int, path: Path) -> np.ndarray | None:
    """``arrays[key]`` as (T, joints, 3) axis-angle, checked; None when absent."""
    if key not in arrays:
        return None
    a = numbers(arrays, key, str(path))
    if a.shape != (T, 3 * joints):
        raise InputError(f"{path}: '{key}' has shape {a.shape}; expected ({T}, {3 * joints})")
    check_rotvecs(a, str(path), f"'{key}'")
    return a.reshape(T, joints, 3)
