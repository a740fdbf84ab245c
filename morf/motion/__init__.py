"""Motions for the avatar: files (BVH, AMASS, our own clips), retargeting onto Anny, foot contact.

Typical use::

    from morf.motion import load_motion, motion_library
    clip = load_motion("walk.bvh", model)       # MotionClip at 30 fps, feet on z = 0
    pose = clip.pose(10)                        # BodyPose for the body model
"""

from morf.motion.clip import MotionClip, load_clip, resample, save_clip
from morf.motion.convert import RetargetConfig, retarget
from morf.motion.ground import GroundConfig, place_on_ground
from morf.motion.library import BUILTIN_MOTIONS, load_motion, motion_library

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
