"""Small sample motions made here from a few sinusoids, directly in Anny's pose parameters:
an idle sway and a walk cycle (in place, and walking forward). Written to resources/motions by

    python -m morf.motion.procedural --out resources/motions

Angles are in degrees about Anny's world-aligned axes (X to the person's left, Y backwards,
Z up), applied in each bone's parent frame: about X, a negative angle swings a hanging limb
forwards; about Y, a positive angle lowers the left arm (negative the right one).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from scipy.spatial.transform import Rotation

from morf.motion.anny_rest import TargetRest, target_rest
from morf.motion.clip import MotionClip, save_clip
from morf.motion.so3 import matrix_to_rotvec
from morf.motion.so3 import swing as swing_rotation
from morf.resources import MOTIONS


def _rot(x=0.0, y=0.0, z=0.0) -> np.ndarray:
    """(T, 3, 3) Rx(x) @ Ry(y) @ Rz(z) for angles in degrees (scalars or (T,) arrays)."""
    x, y, z = np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, dtype=np.float64)) for a in (x, y, z)))
    return Rotation.from_euler("XYZ", np.stack([x, y, z], axis=-1), degrees=True).as_matrix()


def _arm_direction(swing_deg: np.ndarray, side_sign: float, out_deg: float) -> np.ndarray:
    """(T, 3) unit vectors: straight down tilted ``out_deg`` to the side, swung forwards by ``swing_deg``."""
    o = np.radians(out_deg)
    hanging = np.array([side_sign * np.sin(o), 0.0, -np.cos(o)])
    return _rot(x=-np.asarray(swing_deg)) @ hanging


def _relaxed_arms(rest: TargetRest, swing_l: np.ndarray, swing_r: np.ndarray) -> dict[str, np.ndarray]:
    """Arms from Anny's A-pose down to the sides, swinging forwards by ``swing`` degrees, elbows
    bending more as the arm swings forwards. Deltas relative to the chest, from the rest bone
    directions (so the A-pose's raised, bent arms are undone whatever the shape)."""
    out = {}
    h, idx = rest.heads, rest.index
    for s, sign, swing in (("L", 1.0, swing_l), ("R", -1.0, swing_r)):
        d_up = h[idx(f"lowerarm01.{s}")] - h[idx(f"upperarm01.{s}")]
        d_fore = h[idx(f"wrist.{s}")] - h[idx(f"lowerarm01.{s}")]
        bend = 12.0 + 0.6 * np.clip(swing, 0.0, None)
        up_dir = _arm_direction(swing, sign, 9.0)
        fore_dir = _arm_direction(swing + bend, sign, 4.0)
        M_up = np.stack([swing_rotation(d_up, u) for u in up_dir])
        M_fore = np.stack([swing_rotation(m @ d_fore, f) @ m for m, f in zip(M_up, fore_dir)])
        out[f"upperarm01.{s}"] = M_up
        out[f"lowerarm01.{s}"] = np.swapaxes(M_up, -1, -2) @ M_fore
    return out


def idle_sway(rest: TargetRest, fps: float = 30.0, seconds: float = 4.0) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Weight shifting from foot to foot with breathing; loops every ``seconds``."""
    t = np.arange(int(round(seconds * fps))) / fps
    w = 2 * np.pi * t / seconds
    shift = np.sin(w)  # -1 .. 1: weight on the right .. left foot
    breath = np.sin(2 * w)
    rots = _relaxed_arms(rest, 3.0 * np.sin(w + 0.5), 3.0 * np.sin(w + 0.5))
    rots["root"] = _rot(y=2.0 * shift, z=3.0 * np.sin(w + 1.0))
    rots["spine03"] = _rot(x=1.0 * breath, y=-1.5 * shift)
    rots["spine01"] = _rot(x=-1.5 * breath, y=-1.0 * shift)
    rots["neck01"] = _rot(x=2.0 * np.sin(w + 2.0), z=4.0 * np.sin(w + 2.0))
    for s, sign in (("L", 1.0), ("R", -1.0)):
        # The leg under the weight stays straight; the other knee relaxes.
        relax = np.clip(-sign * shift, 0.0, None)
        rots[f"upperleg01.{s}"] = _rot(x=-6.0 * relax, y=-sign * 2.0 * shift)
        rots[f"lowerleg01.{s}"] = _rot(x=12.0 * relax)
        rots[f"foot.{s}"] = _rot(x=-6.0 * relax)
    transl = np.stack([0.03 * shift, np.zeros_like(t), np.zeros_like(t)], axis=1)
    return rots, transl


def _bump(c: np.ndarray, centre: float, width: float) -> np.ndarray:
    """Periodic Gaussian bump over the gait cycle fraction ``c`` in [0, 1)."""
    d = (c - centre + 0.5) % 1.0 - 0.5
    return np.exp(-0.5 * (d / width) ** 2)


def walk_cycle(rest: TargetRest, fps: float = 30.0, period: float = 1.1, cycles: int = 4) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """A walk in place: ``cycles`` gait cycles of ``period`` seconds (loops seamlessly).

    Joint angle curves follow the textbook shape of normal gait over the cycle (0 = heel strike):
    hip flexion peaks late in swing, the knee bends a little on loading and most in early
    swing, the ankle pushes off before toe-off (about 60% of the cycle).
    """
    t = np.arange(int(round(cycles * period * fps))) / fps
    phase = (t / period) % 1.0
    rots, hips = {}, {}
    for s, off in (("L", 0.0), ("R", 0.5)):
        c = (phase + off) % 1.0
        hip = 8.0 + 18.0 * np.cos(2 * np.pi * (c - 0.95))  # + forwards
        knee = 4.0 + 14.0 * _bump(c, 0.15, 0.07) + 60.0 * _bump(c, 0.7, 0.13)
        ankle = 6.0 * _bump(c, 0.07, 0.05) - 8.0 * _bump(c, 0.4, 0.1) + 18.0 * _bump(c, 0.58, 0.07)  # + toes down
        rots[f"upperleg01.{s}"] = _rot(x=-hip)
        rots[f"lowerleg01.{s}"] = _rot(x=knee)
        rots[f"foot.{s}"] = _rot(x=ankle)
        hips[s] = hip - 8.0
    # Each arm swings with the opposite leg.
    rots.update(_relaxed_arms(rest, 0.8 * hips["R"], 0.8 * hips["L"]))
    turn = hips["L"] - hips["R"]  # > 0 while the left leg is forwards
    rots["root"] = _rot(x=-3.0, z=-0.15 * turn)
    rots["spine02"] = _rot(x=1.0, z=0.25 * turn)
    rots["neck01"] = _rot(x=2.0, z=-0.05 * turn)
    sway = np.sin(2 * np.pi * phase)  # weight over the stance foot: left early in the cycle
    transl = np.stack([0.02 * sway, np.zeros_like(t), np.zeros_like(t)], axis=1)
    return rots, transl


def to_clip(rots: dict[str, np.ndarray], transl: np.ndarray, bone_names, fps: float, name: str) -> MotionClip:
    """Per-bone (T, 3, 3) deltas (missing bones: identity) -> a clip."""
    T = transl.shape[0]
    rotvecs = np.zeros((T, len(bone_names), 3))
    for bone, R in rots.items():
        rotvecs[:, bone_names.index(bone)] = matrix_to_rotvec(np.asarray(R))
    return MotionClip(rotvecs.astype(np.float32), transl.astype(np.float32), fps, name, "procedural (morf.motion.procedural)")


def walk_forward(in_place: MotionClip, model) -> MotionClip:
    """The in-place walk moved on so that the lower foot (the stance foot) stays where it is planted."""
    from morf.motion.ground import foot_points, foot_sides

    pts = foot_points(in_place, model)
    left, right = foot_sides(model, None)
    feet = np.stack([pts[:, left], pts[:, right]], axis=1)  # (T, 2, 3 points, 3)
    stance = feet[..., 2].min(axis=2).argmin(axis=1)  # which foot is lower
    centre = feet[..., :2].mean(axis=2)  # (T, 2, 2)
    T = in_place.num_frames
    step = np.zeros((T, 2))
    now, before = np.arange(1, T), np.arange(T - 1)
    step[1:] = -(centre[now, stance[1:]] - centre[before, stance[1:]])
    transl = in_place.transl.astype(np.float64).copy()
    transl[:, :2] += np.cumsum(step, axis=0)
    return MotionClip(in_place.rotvecs, transl.astype(np.float32), in_place.fps, "walk_forward", in_place.source)


def build_samples(model, fps: float = 30.0) -> list[MotionClip]:
    """The bundled sample clips, feet on the floor (z = 0)."""
    from morf.motion.ground import GroundConfig, place_on_ground

    names = list(model.bone_names)
    rest = target_rest(model)
    flat = GroundConfig(reduce_sliding=False)
    idle = place_on_ground(to_clip(*idle_sway(rest, fps), names, fps, "idle_sway"), model, config=flat)
    walk = place_on_ground(to_clip(*walk_cycle(rest, fps), names, fps, "walk_in_place"), model, config=flat)
    long_walk = place_on_ground(to_clip(*walk_cycle(rest, fps, cycles=6), names, fps, "walk"), model, config=flat)
    return [idle, walk, walk_forward(long_walk, model)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Write the procedural sample motions as .npz clips.")
    ap.add_argument("--out", default=str(MOTIONS), help="output folder (default: the shipped motions)")
    ap.add_argument("--fps", type=float, default=30.0)
    args = ap.parse_args(argv)
    from morf.body import load_body_model

    model = load_body_model("anny")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for clip in build_samples(model, args.fps):
        save_clip(clip, out / f"{clip.name}.npz")
        speed = np.linalg.norm(clip.transl[-1, :2] - clip.transl[0, :2]) / max(clip.duration, 1e-9)
        print(f"{clip.name}: {clip.num_frames} frames at {clip.fps:g} fps, mean speed {speed:.2f} m/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
