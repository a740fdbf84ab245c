"""An orbit camera for the live render: the mouse turns it around the avatar and zooms."""

from __future__ import annotations

import math
from dataclasses import dataclass

from morf.camera import PinholeCamera


@dataclass
class OrbitCamera:
    """Orbit around ``target`` (Anny's world: Z up, the body faces -Y, pelvis at the origin)."""

    yaw_deg: float = 0.0  # 0: in front of the person (on -Y), looking at them
    pitch_deg: float = 5.0  # above the horizon
    distance_m: float = 3.0
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    fov_y_deg: float = 40.0

    def drag(self, dx_px: float, dy_px: float) -> None:
        """Mouse drag by (dx, dy) pixels: turn around the person and tilt."""
        self.yaw_deg = (self.yaw_deg - 0.4 * dx_px) % 360.0
        self.pitch_deg = max(-80.0, min(80.0, self.pitch_deg + 0.3 * dy_px))

    def zoom(self, wheel: float) -> None:
        """Mouse wheel: move closer (wheel > 0) or further away."""
        self.distance_m = max(0.5, min(20.0, self.distance_m * (0.9 ** wheel)))

    def camera(self, width: int, height: int) -> PinholeCamera:
        """The pinhole camera for an image of ``width`` x ``height`` pixels."""
        yaw, pitch = math.radians(self.yaw_deg), math.radians(self.pitch_deg)
        tx, ty, tz = self.target
        eye = (tx + self.distance_m * math.cos(pitch) * math.sin(yaw),
               ty - self.distance_m * math.cos(pitch) * math.cos(yaw),
               tz + self.distance_m * math.sin(pitch))
        return PinholeCamera.look_at(width, height, self.fov_y_deg, eye, self.target)
