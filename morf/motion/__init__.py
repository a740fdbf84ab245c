"""Motions for the avatar: files (BVH, AMASS, our own clips), retargeting onto Anny, foot contact.

Typical use::

    from morf.motion import load_motion, motion_library
    clip = load_motion("walk.bvh", model)       # MotionClip at 30 fps, feet on z = 0
    pose = clip.pose(10)                        # BodyPose for the body model

Importing the package and its clips needs no torch (the torch-free player reads motions through
it); retargeting and ground contact (``retarget``, ``place_on_ground`` and their configs) use the
body model and are loaded on first use.
"""

from morf.lazy import lazy_attributes
from morf.motion.clip import MotionClip, load_clip, resample, save_clip
from morf.motion.library import BUILTIN_MOTIONS, load_motion, motion_library

# ``retarget`` is the function of morf.motion.convert; the rotation math it uses is the submodule
# ``retargeting``, so no submodule shadows the name.
__getattr__, __dir__ = lazy_attributes(__name__, {
    "RetargetConfig": "morf.motion.convert", "retarget": "morf.motion.convert",
    "GroundConfig": "morf.motion.ground", "place_on_ground": "morf.motion.ground"})

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
