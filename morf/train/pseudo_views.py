"""Extreme poses and views for the inpainting fine-tune: arms raised or held forward, legs
apart, the body seen from the back, the sides, from above and from below.

The body is posed with the training shape and re-centred where the training frames had it,
then rasterized with the training camera (views from above/below tilt the body about the
camera's horizontal axis, which is the same as moving the camera over / under it).
"""

from __future__ import annotations

import numpy as np
import torch

from morf.body.rotations import axis_angle_to_matrix, matrix_to_axis_angle
from morf.camera import PinholeCamera

# (bone, axis-angle) per pose variant; Anny bone rotations are in world-aligned axes
# (Z up, the body faces -Y, its left is +X): about -Y raises the left arm, about +Y the right.
POSES = {
    "a-pose": {},
    "arms-up": {"upperarm01.L": (0, -2.0, 0), "upperarm01.R": (0, 2.0, 0)},
    "arms-forward": {"upperarm01.L": (-1.4, 0, 0), "upperarm01.R": (-1.4, 0, 0),
                     "lowerarm01.L": (0.6, 0, 0), "lowerarm01.R": (0.6, 0, 0)},
    "legs-apart": {"upperleg01.L": (0, -0.5, 0), "upperleg01.R": (0, 0.5, 0),
                   "upperarm01.L": (0, -1.2, 0), "upperarm01.R": (0, 1.2, 0)},
}
# (yaw about the body's up axis, tilt about the camera's x axis), degrees.
VIEWS = [(0, 0), (180, 0), (90, 0), (-90, 0), (0, 55), (0, -55), (180, 55), (180, -55)]


def _rot(axis: np.ndarray, deg: float) -> np.ndarray:
    axis = np.asarray(axis, float)
    axis = axis / (np.linalg.norm(axis) + 1e-12)
    return axis_angle_to_matrix(torch.from_numpy(axis * np.deg2rad(deg))).numpy()


def extreme_poses(model, base_rotvecs: np.ndarray, camera: PinholeCamera, n: int) -> np.ndarray:
    """(n, J, 3) rotvecs: pose variants x views, cycling so every view appears early.

    ``base_rotvecs`` (J, 3) is a training frame's pose; its root gives the facing direction.
    """
    names = list(model.bone_names)
    R0 = axis_angle_to_matrix(torch.from_numpy(base_rotvecs[0]).double()).numpy()
    up = R0 @ np.array([0.0, 0.0, 1.0])
    cam_x = camera.R[0]
    out = []
    variants = list(POSES.values())
    for k in range(n):
        pose = variants[(k // len(VIEWS) + k) % len(variants)]
        yaw, tilt = VIEWS[k % len(VIEWS)]
        r = np.zeros((len(names), 3), np.float32)
        for bone, aa in pose.items():
            if bone in names:
                r[names.index(bone)] = aa
        root = _rot(cam_x, tilt) @ _rot(up, yaw) @ R0
        r[0] = matrix_to_axis_angle(torch.from_numpy(root)).numpy()
        out.append(r)
    return np.stack(out).astype(np.float32)


def make_pseudo_views(model, shape: np.ndarray, camera: PinholeCamera, base_rotvecs: np.ndarray,
                      centre_transl: np.ndarray, n: int, offsets: np.ndarray | None = None
                      ) -> tuple[torch.Tensor, torch.Tensor]:
    """Rasterize ``n`` extreme views of the body (dressed by clothing ``offsets`` (V,) when given).
    Returns uv (n, H, W, 2) float32 and uv_mask (n, H, W) bool tensors."""
    from morf.body.render_mesh import render_mesh_for
    from morf.raster import rasterize_uv_batch
    from morf.train.data import posed_render_vertices

    rot = extreme_poses(model, base_rotvecs, camera, n)
    tr = np.repeat(centre_transl.reshape(1, 3), n, 0).astype(np.float32)
    ref = posed_render_vertices(model, base_rotvecs[None], centre_transl.reshape(1, 3).astype(np.float32), shape,
                                offsets)[0]
    verts = posed_render_vertices(model, rot, tr, shape, offsets)
    centre = 0.5 * (ref.min(0) + ref.max(0))
    verts = verts - (0.5 * (verts.min(1) + verts.max(1)) - centre)[:, None]
    r = rasterize_uv_batch(verts, render_mesh_for(model), camera)
    return torch.from_numpy(np.ascontiguousarray(r.uv)), torch.from_numpy(r.mask)
