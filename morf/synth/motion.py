"""Pose sequences for synthetic captures (Anny "local-ref" axis-angle, world-aligned axes).

The capture follows the paper's protocol: the person turns once around in place, slowly, arms
a little away from the body, with a small natural sway, then faces the camera and shows the
hands in front of the torso. The hold-out sequence uses poses the capture never shows (arms
raised, hip sway, steps), to measure how an avatar generalises.

Sign conventions (checked on renders; Anny is Z up and faces -Y, the person's left is +X):
a rotation about -Y raises the left arm sideways (+Y the right arm); about -X it swings a
hanging limb forwards; yaw of the whole body is a rotation of ``root`` about +Z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.body.rotations import axis_angle_to_matrix, matrix_to_axis_angle


@dataclass(frozen=True)
class MotionSequence:
    """Poses of N frames.

    Fields:
        rotvecs: (N, J, 3) float32 axis-angle per bone (bone 0 = root: yaw and sway).
        transl: (N, 3) float32 root translation in metres.
        yaw: (N,) float32 body yaw in radians (0 = facing the camera on -Y).
        phase: (N,) str what the person is doing ("turn", "hands", "arms", "sway", "step").
    """

    rotvecs: np.ndarray
    transl: np.ndarray
    yaw: np.ndarray
    phase: np.ndarray

    def take(self, frames: np.ndarray) -> "MotionSequence":
        """The frames ``frames`` (indices) of this sequence, in that order."""
        return MotionSequence(self.rotvecs[frames], self.transl[frames], self.yaw[frames], self.phase[frames])


def view_frames(yaw: np.ndarray, phase: np.ndarray, views: int, turn_degrees: float) -> np.ndarray:
    """(views,) indices of the turn's frames nearest ``views`` headings evenly spread over the turn
    (0, 45, ..., 315 degrees for 8 views of a full turn): what a few photos of the turn show.

    A full turn ends where it began, so its headings are spread over 360 degrees without the end;
    a partial turn's include both ends."""
    turn = np.flatnonzero(phase == "turn")
    if views < 1 or len(turn) == 0:
        return np.zeros(0, np.int64)
    full = turn_degrees >= 360.0
    span = np.deg2rad(turn_degrees)
    targets = np.arange(views) * span / (views if full or views == 1 else views - 1)
    nearest = turn[np.abs(yaw[turn][None, :] - targets[:, None]).argmin(1)]
    return np.unique(nearest)


class _PoseBuilder:
    """Accumulates per-bone axis-angle for N frames by bone name."""

    def __init__(self, bone_names: list[str], n: int):
        self.index = {name: i for i, name in enumerate(bone_names)}
        self.rot = np.zeros((n, len(bone_names), 3))

    def add(self, bone: str, axis: tuple[float, float, float], angle: np.ndarray | float) -> None:
        # Small-angle sums stay close to the composed rotation; large motions use one axis per bone.
        self.rot[:, self.index[bone]] += np.asarray(axis, float)[None, :] * np.broadcast_to(angle, self.rot.shape[:1])[:, None]

    def root_with_yaw(self, yaw: np.ndarray) -> None:
        """Compose the body yaw (about +Z, applied last) with the root's small sway rotation."""
        tilt = axis_angle_to_matrix(torch.as_tensor(self.rot[:, 0]))
        yaw_vec = torch.zeros(len(yaw), 3, dtype=torch.float64)
        yaw_vec[:, 2] = torch.as_tensor(yaw)
        R = axis_angle_to_matrix(yaw_vec) @ tilt
        self.rot[:, 0] = matrix_to_axis_angle(R).numpy()


def _slow_wave(t: np.ndarray, rng: np.random.Generator, cycles: tuple[float, float]) -> np.ndarray:
    """A smooth random signal in about [-1, 1]: two sines of a few cycles over the sequence."""
    f1, f2 = rng.uniform(*cycles, size=2)
    p1, p2 = rng.uniform(0, 2 * np.pi, size=2)
    return 0.7 * np.sin(2 * np.pi * f1 * t + p1) + 0.3 * np.sin(2 * np.pi * f2 * t + p2)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0, 1)
    return x * x * (3 - 2 * x)


def capture_motion(bone_names: list[str], n: int, rng: np.random.Generator, turn_fraction: float = 0.8,
                   sway: float = 1.0, arms_out_deg: float = 12.0, turn_degrees: float = 360.0) -> MotionSequence:
    """Turn 360 degrees in place, then show the hands in front of the torso.

    Args:
        n: number of frames; turn_fraction: share of frames spent turning.
        sway: scale of the natural sway (0 = a statue on a turntable).
        arms_out_deg: how far the arms are raised sideways beyond Anny's rest A-pose.
        turn_degrees: how far the person turns (360: all the way round).
    """
    t = np.linspace(0.0, 1.0, n)
    n_turn = n if n < 4 else max(2, int(round(n * turn_fraction)))
    s = np.clip(np.arange(n) / max(n_turn - 1, 1), 0, 1)
    # Eased so the turn starts and ends gently, but never stops mid-way.
    yaw = np.deg2rad(turn_degrees) * (s - 0.35 * np.sin(2 * np.pi * s) / (2 * np.pi))
    hands = np.arange(n) >= n_turn
    b = _smoothstep((np.arange(n) - n_turn) / max(0.4 * (n - n_turn), 1)) * hands

    p = _PoseBuilder(bone_names, n)
    out = np.deg2rad(arms_out_deg)
    p.add("upperarm01.L", (0, -1, 0), out + 0.03 * sway * _slow_wave(t, rng, (1, 3)))
    p.add("upperarm01.R", (0, 1, 0), out + 0.03 * sway * _slow_wave(t, rng, (1, 3)))
    # Hands in front of the torso: upper arms down (undo the A-pose), a little forwards and turned
    # in, forearms raised; the hands then wave slowly. Right = left mirrored: (x, -y, -z).
    wave = 0.2 * np.sin(2 * np.pi * 2 * np.clip((np.arange(n) - n_turn) / max(n - n_turn, 1), 0, 1))
    for side, sgn in (("L", 1), ("R", -1)):
        p.add(f"upperarm01.{side}", (0, sgn, 0), (0.8 + np.deg2rad(arms_out_deg)) * b)
        p.add(f"upperarm01.{side}", (-1, 0, 0), 0.3 * b)
        p.add(f"upperarm01.{side}", (0, 0, -sgn), (0.8 + wave) * b)
        p.add(f"lowerarm01.{side}", (-1, 0, 0), 0.9 * b)
    # Natural sway: pelvis roll and pitch, spine and head counter-motion, weight shifts.
    p.add("root", (1, 0, 0), np.deg2rad(1.5) * sway * _slow_wave(t, rng, (0.5, 2)))
    p.add("root", (0, 1, 0), np.deg2rad(2.0) * sway * _slow_wave(t, rng, (0.5, 2)))
    p.add("spine03", (0, 1, 0), np.deg2rad(-2.0) * sway * _slow_wave(t, rng, (0.5, 2)))
    p.add("neck01", (0, 0, 1), np.deg2rad(4.0) * sway * _slow_wave(t, rng, (1, 3)))
    p.add("head", (1, 0, 0), np.deg2rad(3.0) * sway * _slow_wave(t, rng, (1, 3)))
    p.root_with_yaw(yaw)
    transl = np.zeros((n, 3))
    transl[:, 0] = 0.015 * sway * _slow_wave(t, rng, (0.5, 2))
    transl[:, 1] = 0.010 * sway * _slow_wave(t, rng, (0.5, 2))
    phase = np.where(hands, "hands", "turn")
    return MotionSequence(p.rot.astype(np.float32), transl.astype(np.float32), yaw.astype(np.float32), phase)


def holdout_motion(bone_names: list[str], n: int, rng: np.random.Generator) -> MotionSequence:
    """Novel poses never seen in the capture: arm raises, hip sway, steps, at varied yaw.

    The sequence is split into three equal parts, one per kind of motion; inside each part the
    motion goes out and back once, and the body yaw swings between about +-60 degrees.
    """
    idx = np.arange(n)
    part = np.minimum(idx * 3 // max(n, 1), 2)
    local = np.zeros(n)
    for k in range(3):
        sel = part == k
        m = int(sel.sum())
        local[sel] = np.sin(np.pi * (np.arange(m) + 0.5) / max(m, 1))  # 0 -> 1 -> 0
    yaw = np.deg2rad(60) * np.sin(2 * np.pi * (idx + 0.5) / max(n, 1) + rng.uniform(0, 2 * np.pi))

    p = _PoseBuilder(bone_names, n)
    arms, sway, step = (part == 0) * local, (part == 1) * local, (part == 2) * local
    # Arms: raised sideways towards horizontal and beyond, the right a little ahead of the left.
    p.add("upperarm01.L", (0, -1, 0), np.deg2rad(80) * arms)
    p.add("upperarm01.R", (0, 1, 0), np.deg2rad(92) * arms)
    # Hip sway: the pelvis shifts and tilts, the spine leans the other way, one knee gives.
    p.add("root", (0, 1, 0), np.deg2rad(8) * sway)
    p.add("spine03", (0, 1, 0), np.deg2rad(-10) * sway)
    p.add("spine01", (0, 1, 0), np.deg2rad(-6) * sway)
    p.add("upperleg01.L", (0, 1, 0), np.deg2rad(-8) * sway)
    p.add("lowerleg01.R", (1, 0, 0), np.deg2rad(15) * sway)
    # Steps: one thigh forwards, the other back, knees bent, arms swinging opposite.
    p.add("upperleg01.L", (-1, 0, 0), np.deg2rad(30) * step)
    p.add("lowerleg01.L", (1, 0, 0), np.deg2rad(35) * step)
    p.add("upperleg01.R", (-1, 0, 0), np.deg2rad(-15) * step)
    p.add("lowerleg01.R", (1, 0, 0), np.deg2rad(10) * step)
    p.add("upperarm01.L", (-1, 0, 0), np.deg2rad(-25) * step)
    p.add("upperarm01.R", (-1, 0, 0), np.deg2rad(25) * step)
    p.root_with_yaw(yaw)
    transl = np.zeros((n, 3))
    transl[:, 0] = 0.06 * sway
    transl[:, 1] = -0.05 * step
    phase = np.array(["arms", "sway", "step"])[part]
    return MotionSequence(p.rot.astype(np.float32), transl.astype(np.float32), yaw.astype(np.float32), phase)
