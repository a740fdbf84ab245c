"""Pinhole camera used everywhere (fitting, rasterization, synthetic captures, playback).

Conventions (OpenCV): a world point X maps to camera coordinates ``Xc = R @ X + t``; the camera
looks along +Z, image x to the right, image y down. Pixel centres sit at integer + 0.5, so the
image spans [0, W] x [0, H] and ``u = fx * Xc/Zc + cx``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

# GL's front-face winding for meshes drawn with PinholeCamera.gl_projection: its y flip turns
# triangles counter-clockwise seen from outside into clockwise ones in window coordinates
GL_FRONT_FACE = "cw"

# torch is imported inside the projection functions only: the exported-avatar player uses this
# camera without torch installed.
if TYPE_CHECKING:
    import torch


@dataclass(frozen=True)
class PinholeCamera:
    """Intrinsics and extrinsics of one static camera.

    Fields:
        fx, fy, cx, cy: intrinsics in pixels.
        width, height: image size in pixels.
        R: (3, 3) world-to-camera rotation.
        t: (3,) world-to-camera translation (metres).
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    t: np.ndarray = field(default_factory=lambda: np.zeros(3))

    # ---- construction -------------------------------------------------------------------
    @staticmethod
    def from_fov(width: int, height: int, fov_y_deg: float, R=None, t=None) -> "PinholeCamera":
        f = 0.5 * height / math.tan(math.radians(fov_y_deg) / 2)
        return PinholeCamera(f, f, width / 2, height / 2, width, height,
                             np.eye(3) if R is None else np.asarray(R, float),
                             np.zeros(3) if t is None else np.asarray(t, float))

    @staticmethod
    def default_for_image(width: int, height: int, focal_factor: float = 1.2) -> "PinholeCamera":
        """Camera with no metadata: focal length = ``focal_factor`` * max(W, H) (about 45 deg)."""
        f = focal_factor * max(width, height)
        return PinholeCamera(f, f, width / 2, height / 2, width, height)

    @staticmethod
    def look_at(width: int, height: int, fov_y_deg: float, eye, target, up=(0, 0, 1)) -> "PinholeCamera":
        """A camera at ``eye`` looking at ``target``; ``up`` (world) maps to image up (-y)."""
        eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
        z = target - eye
        z /= np.linalg.norm(z)
        x = np.cross(z, up)
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        R = np.stack([x, y, z])
        return PinholeCamera.from_fov(width, height, fov_y_deg, R=R, t=-R @ eye)

    # ---- accessors ----------------------------------------------------------------------
    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])

    @property
    def position(self) -> np.ndarray:
        """Camera centre in world coordinates."""
        return -self.R.T @ self.t

    def scaled(self, s: float) -> "PinholeCamera":
        """The same camera for an image resized by ``s``."""
        return PinholeCamera(self.fx * s, self.fy * s, self.cx * s, self.cy * s,
                             int(round(self.width * s)), int(round(self.height * s)), self.R, self.t)

    def to_dict(self) -> dict:
        return {"fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy,
                "width": self.width, "height": self.height,
                "R": np.asarray(self.R).tolist(), "t": np.asarray(self.t).tolist()}

    @staticmethod
    def from_dict(d: dict) -> "PinholeCamera":
        return PinholeCamera(float(d["fx"]), float(d["fy"]), float(d["cx"]), float(d["cy"]),
                             int(d["width"]), int(d["height"]),
                             np.asarray(d.get("R", np.eye(3)), float), np.asarray(d.get("t", np.zeros(3)), float))

    # ---- projection (torch, differentiable) ----------------------------------------------
    def world_to_camera(self, points: torch.Tensor) -> torch.Tensor:
        """(..., 3) world points -> (..., 3) camera coordinates."""
        import torch

        R = torch.as_tensor(self.R, dtype=points.dtype, device=points.device)
        t = torch.as_tensor(self.t, dtype=points.dtype, device=points.device)
        return points @ R.T + t

    def project(self, points: torch.Tensor) -> torch.Tensor:
        """(..., 3) world points -> (..., 2) pixel coordinates (x right, y down)."""
        return project_points(self.world_to_camera(points), self.fx, self.fy, self.cx, self.cy)

    def gl_projection(self, near: float = 0.05, far: float = 100.0) -> np.ndarray:
        """4x4 OpenGL clip matrix that, applied to camera coordinates, matches :meth:`project`.

        The y axis is flipped so that row 0 of a read-back framebuffer is image row 0; that turns a
        mesh's counter-clockwise front faces clockwise in GL's window (:data:`GL_FRONT_FACE`).
        """
        W, H = self.width, self.height
        P = np.zeros((4, 4))
        P[0, 0] = 2 * self.fx / W
        P[0, 2] = 2 * self.cx / W - 1
        P[1, 1] = 2 * self.fy / H
        P[1, 2] = 2 * self.cy / H - 1
        P[2, 2] = (far + near) / (far - near)
        P[2, 3] = -2 * far * near / (far - near)
        P[3, 2] = 1.0
        return P

    def view_matrix(self) -> np.ndarray:
        """4x4 world-to-camera matrix."""
        V = np.eye(4)
        V[:3, :3] = self.R
        V[:3, 3] = self.t
        return V


def project_points(xc: torch.Tensor, fx: float, fy: float, cx: float, cy: float, eps: float = 1e-6) -> torch.Tensor:
    """Perspective projection of camera-space points (..., 3) to pixels (..., 2)."""
    import torch

    z = xc[..., 2:3].clamp_min(eps)
    uv = xc[..., :2] / z
    return torch.cat([uv[..., :1] * fx + cx, uv[..., 1:2] * fy + cy], dim=-1)
