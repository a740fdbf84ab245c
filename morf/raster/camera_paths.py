"""Cameras around the avatar: a fixed front camera, an orbit, a follow camera. Playback and
animation view the avatar through them, and export draws its calibration views with them.

Anny is Z-up and faces -Y, so "front" is on the -Y side. All cameras look at the body's middle
(the pelvis sits at the origin of the rest pose, about 0.9 m above the feet).
"""

from __future__ import annotations

import math

import numpy as np

from morf.camera import PinholeCamera

FOV_Y_DEG = 40.0
DISTANCE = 3.4  # metres: a 1.7 m person fills about 70% of a 40 degree view
TARGET_Z = -0.05  # look slightly below the pelvis, the middle of a standing body


def _look_at(size: int, eye: np.ndarray, target: np.ndarray) -> PinholeCamera:
    return PinholeCamera.look_at(size, size, FOV_Y_DEG, eye=eye, target=target)


def front_camera(size: int, center=(0.0, 0.0, 0.0), yaw_deg: float = 0.0, distance: float = DISTANCE):
    """A square ``size`` camera on the person's front side rotated by ``yaw_deg`` about +Z."""
    c = np.asarray(center, float) + np.array([0.0, 0.0, TARGET_Z])
    a = math.radians(yaw_deg)
    eye = c + distance * np.array([math.sin(a), -math.cos(a), 0.0]) + np.array([0.0, 0.0, 0.15])
    return _look_at(size, eye, c)


def orbit_camera(size: int, t: float, period_s: float = 8.0, center=(0.0, 0.0, 0.0)):
    """The camera at time ``t`` seconds of an orbit around ``center`` (one turn per ``period_s``)."""
    return front_camera(size, center, yaw_deg=360.0 * t / period_s)


def follow_camera(size: int, transl) -> PinholeCamera:
    """A front camera that keeps the root translation ``transl`` (3,) centred (height kept fixed)."""
    tr = np.asarray(transl, float)
    return front_camera(size, center=(tr[0], tr[1], 0.0))
