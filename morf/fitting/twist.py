"""Pelvis-shoulder twist: how far the shoulders are turned from the hips about the trunk's axis.

A fit can explain a person's keypoints with a body whose pelvis faces the other way from its
shoulders: the spine bones twist through half a turn, the thighs turn back under it and the
legs cross. Each bone alone may stay near its joint limits; the body as a whole cannot be. This
measure sees it directly, on the body's own 3D keypoints: the hip line (left hip to right hip)
against the shoulder line, both projected onto the plane normal to the trunk (hip midpoint to
shoulder midpoint). A standing person rarely twists more than 30-40 degrees there (the spine's
whole axial range is about 40 degrees each way).

Used three ways: a penalty in the fit beyond ``limit_deg`` (:func:`twist_penalty`), a reason for
the frame filter, and a score of fits against synthetic ground truth.
"""

from __future__ import annotations

import numpy as np
import torch

L_SHOULDER, R_SHOULDER, L_HIP, R_HIP = 5, 6, 11, 12


def twist_angle(keypoints3d: torch.Tensor) -> torch.Tensor:
    """(N,) signed pelvis-shoulder twist in radians from (N, 23, 3) COCO(+feet) 3D keypoints
    (positive: the shoulders turned counter-clockwise from the hips, seen from above the head)."""
    kp = keypoints3d
    hips = kp[:, L_HIP] - kp[:, R_HIP]
    shoulders = kp[:, L_SHOULDER] - kp[:, R_SHOULDER]
    up = 0.5 * (kp[:, L_SHOULDER] + kp[:, R_SHOULDER]) - 0.5 * (kp[:, L_HIP] + kp[:, R_HIP])
    up = up / up.norm(dim=-1, keepdim=True).clamp_min(1e-9)
    h = hips - (hips * up).sum(-1, keepdim=True) * up
    s = shoulders - (shoulders * up).sum(-1, keepdim=True) * up
    sin = (torch.linalg.cross(h, s, dim=-1) * up).sum(-1)
    cos = (h * s).sum(-1)
    return torch.atan2(sin, cos)


def twist_deg(keypoints3d: np.ndarray) -> np.ndarray:
    """(N,) absolute pelvis-shoulder twist in degrees (numpy in and out)."""
    kp = torch.as_tensor(np.asarray(keypoints3d, np.float64))
    return np.degrees(np.abs(twist_angle(kp).numpy()))


def twist_penalty(keypoints3d: torch.Tensor, limit_deg: float) -> torch.Tensor:
    """(N,) squared excess of the twist over ``limit_deg``, radians^2; zero within it.

    Measured as ``1 - cos`` rather than the angle near half a turn, where atan2 jumps from +pi to
    -pi: the penalty must keep pushing a body twisted by 180 degrees back, not flip its sign."""
    angle = twist_angle(keypoints3d)
    # 2 (1 - cos a) equals a^2 near 0 and keeps growing up to a = pi, with no jump
    excess = 2.0 * (torch.cos(torch.tensor(np.deg2rad(limit_deg), dtype=angle.dtype)) - torch.cos(angle))
    return torch.relu(excess) ** 2
