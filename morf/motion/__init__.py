"""Motions for the avatar: files (BVH, AMASS, our own clips), retargeting onto Anny, foot contact.

Typical use::

    from morf.motion import load_motion, motion_library
    clip = load_motion("walk.bvh", model)       # MotionClip at 30 fps, feet on z = 0
    pose = clip.pose(10)                        # BodyPose for the body model

Importing the package and its clips needs no torch (the torch-free player reads motions through
it); retargeting and ground contact (``retarget``, ``place_on_ground`` and their configs) use the
body model and are loaded on first use.
"""

import importlib

from morf.motion.clip import MotionClip, load_clip, resample, save_clip
from morf.motion.library import BUILTIN_MOTIONS, load_motion, motion_library

# ``retarget`` here is the function of morf.motion.convert, not the submodule of that name: the
# submodule (torch-free) is loaded now and dropped from this namespace, so the name resolves below.
importlib.import_module("morf.motion.retarget")
del globals()["retarget"]

_LAZY = {"RetargetConfig": "morf.motion.convert", "retarget": "morf.motion.convert",
         "GroundConfig": "morf.motion.ground", "place_on_ground": "morf.motion.ground"}

__all__ = [
    "BUILTIN_MOTIONS",
    "GroundConfig",
    "MotionClip",
    "RetargetConfig",
    "load_clip",
    "load_motion",
    "motion_library",
    "place_on_ground",
    "resample",
    "retarget",
    "save_clip",
]


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'morf.motion' has no attribute {name!r}")
