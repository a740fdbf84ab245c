"""Fingers and eyes of the SMPL-H / SMPL-X bodies, for the Anny bones that have them.

SMPL-H and SMPL-X store 15 joints per hand (the MANO order below, left hand first) and SMPL-X
two eyes; Anny has three bones per finger (finger1 = thumb .. finger5 = little finger) and two
eyes, so every one of them maps one to one. Anny has no jaw: a SMPL-X jaw rotation is left out
(the reader says so).

A finger rotation is applied as a turn from Anny's own rest hand (no rest direction is matched,
see :mod:`morf.motion.joint_maps`): zero hand poses keep Anny's rest hand whether the file means a
flat hand (AMASS) or the model's mean hand (the ``smplx`` package's default), and a bend bends
Anny's finger by the same angle about the same axis.

The rest positions are approximate (about a centimetre), like :data:`morf.motion.amass.SMPL_REST`:
retargeting uses none of them for these joints; they only place the source joints for checks.
"""

from __future__ import annotations

import numpy as np

# MANO / SMPL-H / SMPL-X order of one hand's 15 joints, and the Anny finger each one drives.
HAND_FINGERS = ("index", "middle", "pinky", "ring", "thumb")
ANNY_FINGER = {"thumb": 1, "index": 2, "middle": 3, "ring": 4, "pinky": 5}

# Offsets of the left hand's finger joints in the SMPL rest pose (Y up, facing +Z, left +X),
# metres: the first joint of each finger from the wrist, then each joint from the one before.
_LEFT_FINGER_OFFSETS = {
    "index": ((0.095, -0.005, 0.025), (0.035, -0.003, 0.0), (0.022, -0.002, 0.0)),
    "middle": ((0.097, -0.008, 0.002), (0.038, -0.003, 0.0), (0.025, -0.002, 0.0)),
    "pinky": ((0.078, -0.012, -0.035), (0.022, -0.003, 0.0), (0.018, -0.002, 0.0)),
    "ring": ((0.090, -0.010, -0.018), (0.033, -0.003, 0.0), (0.024, -0.002, 0.0)),
    "thumb": ((0.030, -0.015, 0.025), (0.025, -0.008, 0.020), (0.022, -0.005, 0.015)),
}
_LEFT_EYE_OFFSET = (0.032, 0.035, 0.065)  # from the head joint


def hand_joint_names(side: str) -> tuple[str, ...]:
    """The 15 joints of the ``side`` ("left" / "right") hand in file order: ``left_index1`` ..."""
    return tuple(f"{side}_{f}{i}" for f in HAND_FINGERS for i in (1, 2, 3))


def detail_joints(wrist: dict[str, int], head: int, first: int) -> tuple[tuple[str, ...], tuple[int, ...], np.ndarray]:
    """Names, parents and offsets (metres, SMPL rest axes) of both hands' 30 joints (left hand
    first, file order) and the two eyes, appended to a skeleton whose joint ``first`` is the next
    free index; ``wrist`` maps "left" / "right" to the wrist joints, ``head`` is the head joint."""
    names, parents, offsets = [], [], []
    for side, sign in (("left", 1.0), ("right", -1.0)):
        for finger in HAND_FINGERS:
            for i, off in enumerate(_LEFT_FINGER_OFFSETS[finger]):
                parents.append(wrist[side] if i == 0 else first + len(names) - 1)
                names.append(f"{side}_{finger}{i + 1}")
                offsets.append((sign * off[0], off[1], off[2]))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        names.append(f"{side}_eye")
        parents.append(head)
        offsets.append((sign * _LEFT_EYE_OFFSET[0], _LEFT_EYE_OFFSET[1], _LEFT_EYE_OFFSET[2]))
    return tuple(names), tuple(parents), np.array(offsets, np.float64)


def detail_bones() -> tuple[tuple[str, str], ...]:
    """(Anny bone, source joint of :func:`detail_joints`) for every finger bone and both eyes."""
    out = []
    for s, side in (("L", "left"), ("R", "right")):
        for finger in HAND_FINGERS:
            out += [(f"finger{ANNY_FINGER[finger]}-{i}.{s}", f"{side}_{finger}{i}") for i in (1, 2, 3)]
        out.append((f"eye.{s}", f"{side}_eye"))
    return tuple(out)
