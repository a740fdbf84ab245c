"""Source motion -> Anny :class:`MotionClip`: retarget, resample, feet on the ground."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from morf.motion.anny_rest import target_rest
from morf.motion.clip import MotionClip, resample
from morf.motion.ground import GroundConfig, place_on_ground
from morf.motion.joint_maps import JointMap
from morf.motion.retargeting import retarget_rotations, turn_and_shift
from morf.motion.skeleton import SourceMotion


@dataclass(frozen=True)
class RetargetConfig:
    """Options of :func:`retarget`."""

    fps: float | None = 30.0  # output frame rate (None keeps the source's)
    face_forward: bool = True  # turn the clip about Z so its first frame faces -Y (the camera side)
    center_start: bool = True  # shift the clip so its first frame's root is at x = y = 0
    keep_feet_on_ground: bool = True  # vertical correction so feet touch the floor (see ground.py)
    ground: GroundConfig = field(default_factory=GroundConfig)


def retarget(source: SourceMotion, model, shape: torch.Tensor | None = None, config: RetargetConfig = RetargetConfig(),
             joint_map: JointMap | None = None, control=None) -> MotionClip:
    """Retarget ``source`` onto the body ``model`` (Anny) with phenotype ``shape`` (1, 6).

    ``joint_map`` defaults to the documented map for the skeleton's joint names, else the fuzzy
    matcher's. Raises InputError when the skeleton cannot be matched.
    """
    rest = target_rest(model, shape)
    r = turn_and_shift(retarget_rotations(source, rest, joint_map), config.face_forward, config.center_start)
    clip = MotionClip(r.rotvecs.astype(np.float32), r.transl.astype(np.float32), float(source.fps), source.name,
                      f"{source.source}, map {r.joint_map.name}, scale {r.scale:.3f}", source.notes)
    clearance = r.clearance
    if config.fps is not None and abs(config.fps - clip.fps) > 1e-6:
        clip = resample(clip, config.fps)
        t_new = np.arange(clip.num_frames) / clip.fps
        clearance = np.interp(t_new, np.arange(len(r.clearance)) / source.fps, r.clearance)
    if config.keep_feet_on_ground:
        clip = place_on_ground(clip, model, shape, clearance, config.ground, control)
    return clip
