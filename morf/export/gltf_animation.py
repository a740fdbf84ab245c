"""A motion as glTF animation data: one rotation sampler per joint and the root's translation.

glTF interpolates rotations with spherical linear interpolation between keyframes, taking the
quaternions as written; consecutive quaternions are therefore sign-aligned (q and -q are the
same rotation, but interpolating between them would spin the long way round).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.export.gltf_rig import pose_nodes
from morf.export.skeleton import SkinningSkeleton
from morf.motion.checks import check_pose_arrays
from morf.records import length_of


@dataclass(frozen=True)
class JointAnimation:
    """Keyframes of a skin's joints.

    Fields:
        name: the animation's name.
        times: (T,) float32 seconds, from 0.
        rotations: (T, J, 4) float32 node-local quaternions (x, y, z, w), glTF axes.
        translations: (T, J, 3) float32 node-local translations, glTF axes (constant but for the
            root's on Anny, whose root reference and rest orientations agree; see
            :func:`moving_joints`).
    """

    name: str
    times: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray

    num_frames = length_of("times")


def align_quaternion_signs(q: np.ndarray) -> np.ndarray:
    """(T, J, 4) quaternions with each frame's sign flipped to agree with the frame before it."""
    out = np.array(q, np.float64)
    for t in range(1, len(out)):
        flip = (out[t] * out[t - 1]).sum(-1) < 0
        out[t, flip] *= -1
    return out


def joint_animation(skeleton: SkinningSkeleton, rotvecs: np.ndarray, transl: np.ndarray, fps: float,
                    name: str = "motion") -> JointAnimation:
    """Keyframes that make the glTF skin follow a motion in the body model's own pose parameters.

    Args:
        skeleton: the shaped skeleton the skin was written from.
        rotvecs: (T, J, 3) axis-angle per bone (Anny "local-ref"); transl: (T, 3) root translation
            (Anny axes); fps: frames per second.
    Raises:
        ValueError: shapes that do not fit the skeleton; InputError: values that are not finite or
            out of range (:mod:`morf.motion.checks`; motion readers refuse such files first).
    """
    rotvecs = np.asarray(rotvecs, np.float64)
    transl = np.asarray(transl, np.float64)
    if rotvecs.ndim != 3 or rotvecs.shape[1:] != (skeleton.num_bones, 3) or transl.shape != (len(rotvecs), 3):
        raise ValueError(f"motion must be rotvecs (T, {skeleton.num_bones}, 3) and transl (T, 3), "
                         f"got {rotvecs.shape} and {transl.shape}")
    if len(rotvecs) == 0:
        raise ValueError("motion needs at least one frame")
    fps = check_pose_arrays(rotvecs, transl, fps, f"motion {name!r}")  # no NaN or 1e30 into a .glb
    quats, trans = [], []
    for r, t in zip(rotvecs, transl):
        q, tr = pose_nodes(skeleton, r, t)
        quats.append(q)
        trans.append(tr)
    times = np.arange(len(rotvecs), dtype=np.float64) / fps
    return JointAnimation(name=name, times=times.astype(np.float32),
                          rotations=align_quaternion_signs(np.stack(quats)).astype(np.float32),
                          translations=np.stack(trans).astype(np.float32))


def moving_joints(animation: JointAnimation, bind_translations: np.ndarray, tol: float = 1e-6) -> list[int]:
    """Joints whose translation leaves the bind pose's: they get a translation channel (the root
    always). A child of the root moves with the pose too when the skeleton's root reference and
    rest orientations differ (:mod:`morf.export.skeleton`: A_0 = I)."""
    moved = np.abs(animation.translations - bind_translations[None]).max(axis=(0, 2)) > tol
    moved[0] = True
    return [int(j) for j in np.nonzero(moved)[0]]
