"""SMPL and SMPL-X parameters split by body part, in .npz: the layout the ``smplx`` body models
take, and that most avatar projects and pose estimators write.

- SMPL: ``global_orient`` (T, 3), ``body_pose`` (T, 69), ``transl`` (T, 3), ``betas``;
- SMPL-X: ``global_orient`` (T, 3), ``body_pose`` (T, 63), ``transl``, ``betas``, and any of
  ``jaw_pose`` (T, 3), ``leye_pose`` / ``reye_pose`` (T, 3), ``left_hand_pose`` /
  ``right_hand_pose`` (T, 45), ``expression`` (T, 10); SMPL-H is the same without the face.

Every rotation may also be (T, J, 3) axis-angle or (T, J, 3, 3) rotation matrices (as some
estimators save them), and a single frame may come without its frame axis (``body_pose``
(69,)). ``transl`` (or ``trans``) is optional: in place. Such files store no frame rate as a rule:
``fps`` / ``mocap_framerate`` when present, else the rate given, else 30 fps. ``betas`` are not
used: the motion is retargeted onto the project's own fitted body.

Their world's axes differ by source (camera space Y down, Y up, Z up), so the up axis is found
from the data as for plain SMPL (:func:`morf.motion.smpl.upright`).

What Anny cannot show is left out: SMPL's two hand joints (``body_pose`` joints 22 and 23, the
whole hand block; as in :mod:`morf.motion.smpl`), the jaw and the expression. Hand poses stored as
PCA coefficients (fewer than 45 numbers a hand) need the licensed SMPL-X model file to decode,
so those hands keep their rest pose. The motion's notes say what was left out.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.motion.amass import face_notes, smpl_source_motion, stored_fps
from morf.motion.checks import check_range, check_rotation_matrices, check_rotvecs, check_translations, numbers
from morf.motion.skeleton import SourceMotion
from morf.motion.smpl import SMPL_DEFAULT_FPS, upright
from morf.motion.so3 import matrix_to_rotvec

SPLIT_KEYS = ("global_orient", "body_pose")
BODY_JOINTS = {23: "smpl", 21: "smplx"}  # joints of body_pose (the root is global_orient)
HAND_KEYS = ("left_hand_pose", "right_hand_pose")
EYE_KEYS = ("leye_pose", "reye_pose")
MAX_EXPRESSION = 1000.0  # expression coefficients are read only to say whether they move


def is_smpl_params(arrays: dict[str, np.ndarray]) -> bool:
    """Whether an .npz holds split SMPL / SMPL-X parameters (told by its keys)."""
    return set(SPLIT_KEYS) <= set(arrays)


def rotation_frames(shape: tuple[int, ...], joints: int) -> list[tuple[str, int]]:
    """Every way ``shape`` can hold ``joints`` rotations per frame: ("axis-angle" | "matrices",
    frame count). A (3, 3) array of one joint is both three axis-angle frames and one matrix."""
    s, n = tuple(shape), joints
    out = []
    if len(s) in (1, 2) and s[-1] == 3 * n:
        out.append(("axis-angle", 1 if len(s) == 1 else s[0]))
    if len(s) in (2, 3) and s[-2:] == (n, 3):
        out.append(("axis-angle", 1 if len(s) == 2 else s[0]))
    if len(s) in (3, 4) and s[-3:] == (n, 3, 3):
        out.append(("matrices", 1 if len(s) == 3 else s[0]))
    elif n == 1 and len(s) in (2, 3) and s[-2:] == (3, 3):
        out.append(("matrices", 1 if len(s) == 2 else s[0]))
    return out


def read_rotations(arrays: dict[str, np.ndarray], key: str, joints: int, path: Path,
                   frames: int | None = None) -> np.ndarray:
    """``arrays[key]`` as (T, joints, 3) axis-angle, checked (:mod:`morf.motion.checks`); ``frames``
    is T when known (it settles a (3, 3) array). InputError for any other shape."""
    a = numbers(arrays, key, str(path))
    forms = [f for f in rotation_frames(a.shape, joints) if frames is None or f[1] == frames]
    if not forms:
        t = "T" if frames is None else str(frames)
        raise InputError(f"{path}: '{key}' has shape {a.shape}; expected ({t}, {3 * joints}) or ({t}, {joints}, 3) "
                         f"axis-angle, or ({t}, {joints}, 3, 3) rotation matrices")
    form, T = forms[0]
    if form == "matrices":
        m = a.reshape(T, joints, 3, 3)
        check_rotation_matrices(m, str(path), f"'{key}'")
        return matrix_to_rotvec(m)
    check_rotvecs(a.reshape(T, 3 * joints), str(path), f"'{key}'")
    return a.reshape(T, joints, 3)


def read_smpl_params(path: str | Path, arrays: dict[str, np.ndarray], fps: float | None = None) -> SourceMotion:
    """Split SMPL / SMPL-X parameters (see the module docstring) as a :class:`SourceMotion` on the
    SMPL body joints, and the fingers and eyes where the file has them.

    ``fps`` is used when the file stores no frame rate (default 30).
    Raises:
        InputError: a missing or misshapen array, or numbers out of range.
    """
    path = Path(path)
    body_pose = None
    for n in BODY_JOINTS:
        if rotation_frames(np.shape(arrays["body_pose"]), n):
            body_pose = read_rotations(arrays, "body_pose", n, path)
            break
    if body_pose is None:
        shape = np.shape(arrays["body_pose"])
        raise InputError(f"{path}: 'body_pose' has shape {shape}; expected (T, 69) SMPL or (T, 63) SMPL-X "
                         "axis-angle (or (T, 23 | 21, 3), or (T, 23 | 21, 3, 3) rotation matrices)")
    T, n = body_pose.shape[:2]
    root = read_rotations(arrays, "global_orient", 1, path, T)
    body = np.concatenate([root, body_pose[:, :21]], axis=1).reshape(T, 66)
    trans, field = _translation(arrays, T, path)
    check_translations(trans, str(path), field)
    notes = []
    hands = _hands(arrays, T, path, notes)
    eyes = None
    if any(k in arrays for k in EYE_KEYS):
        eyes = np.concatenate([read_rotations(arrays, k, 1, path, T) if k in arrays else np.zeros((T, 1, 3))
                               for k in EYE_KEYS], axis=1)
    jaw = read_rotations(arrays, "jaw_pose", 1, path, T) if "jaw_pose" in arrays else None
    expression = None
    if "expression" in arrays:
        expression = numbers(arrays, "expression", str(path))
        check_range(expression, str(path), "'expression'", MAX_EXPRESSION, "", "expression coefficient")
    notes += face_notes(jaw, expression)
    rate = stored_fps(arrays, path) or fps or SMPL_DEFAULT_FPS
    body, trans, axis = upright(body, trans)
    kind = BODY_JOINTS[n]
    return smpl_source_motion(body, trans, rate, axis, path, f"smpl-params:{path.name} ({kind}, {axis}-up)", kind,
                              hands, eyes, tuple(notes))


def _translation(arrays: dict[str, np.ndarray], T: int, path: Path) -> tuple[np.ndarray, str]:
    """(T, 3) translation from ``transl`` (or ``trans``), zeros when there is none; and its field name."""
    key = next((k for k in ("transl", "trans") if k in arrays), None)
    if key is None:
        return np.zeros((T, 3)), "the translation"
    t = numbers(arrays, key, str(path))
    if t.size != 3 * T or t.shape[-1] != 3:
        raise InputError(f"{path}: '{key}' has shape {t.shape}; expected ({T}, 3) like 'body_pose''s {T} frames")
    return t.reshape(T, 3), f"'{key}'"


def _hands(arrays: dict[str, np.ndarray], T: int, path: Path, notes: list[str]) -> np.ndarray | None:
    """(T, 30, 3) both hands (a missing hand at rest), or None when the file has no hand poses;
    PCA hand poses stay at rest and add a note."""
    if not any(k in arrays for k in HAND_KEYS):
        return None
    parts, pca = [], []
    for key in HAND_KEYS:
        shape = np.shape(arrays[key]) if key in arrays else None
        if shape is not None and not rotation_frames(shape, 15) and len(shape) in (1, 2) and 0 < shape[-1] < 45:
            pca.append((key, shape[-1]))
            shape = None
        parts.append(np.zeros((T, 15, 3)) if shape is None else read_rotations(arrays, key, 15, path, T))
    if pca:
        keys = " and ".join(f"'{k}'" for k, _ in pca)
        counts = "/".join(sorted({str(n) for _, n in pca}))
        notes.append(f"{keys} {'hold' if len(pca) > 1 else 'holds'} {counts} PCA coefficients, which only the licensed "
                     f"SMPL-X model file decodes: {'those hands keep' if len(pca) > 1 else 'that hand keeps'} the rest "
                     "pose (save the 45 rotations of each hand to move them)")
    return np.concatenate(parts, axis=1)
