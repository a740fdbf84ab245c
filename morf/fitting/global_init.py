"""Stage 1 of the fit: global orientation and translation of every frame.

The body is held rigid in its rest pose. Depth starts from the torso length in pixels
(shoulder midpoint to hip midpoint against the model's torso length and the focal length);
several orientations about the body's up axis are fitted to the torso and head keypoints in
parallel, and a dynamic programme over the sequence picks one per frame that fits well and
turns little between frames (a person turning in place shows front, side and back views, and a
single start would fall into the mirror-image solution on some of them). What a turn between two
frames costs depends on how far apart they are (:mod:`morf.fitting.frame_spacing`): photos 45
degrees apart may turn 45 degrees, and unordered views pick their headings each on its own.
Every heading is also tried with the keypoints' left and right labels exchanged, and the face's
presence decides between a body seen from the front and its mirror image seen from the back
(:mod:`morf.fitting.heading`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.body.rotations import axis_angle_to_matrix
from morf.camera import PinholeCamera
from morf.errors import InputError
from morf.fitting import frame_spacing
from morf.fitting.adam import Adam
from morf.fitting.frame_spacing import FrameSpacing
from morf.fitting.heading import MIRROR_INDEX, HeadingEvidence, face_seen, facing, heading_costs
from morf.fitting.losses import keypoint_loss
from morf.fitting.params import yaw_candidates, yaw_matrix

SHOULDERS, HIPS = (5, 6), (11, 12)
# nose, eyes, ears, shoulders, hips: points that a rigid rest-pose body can explain
GLOBAL_KEYPOINT_WEIGHTS = {0: 0.5, 1: 0.3, 2: 0.3, 3: 0.5, 4: 0.5, 5: 1.0, 6: 1.0, 11: 1.0, 12: 1.0}


@dataclass(frozen=True)
class GlobalInit:
    """Fields:
        root: (N, 3, 3) root rotations; transl: (N, 3) translations (metres).
        loss: (N,) keypoint loss of the chosen hypothesis.
        spacing: how far apart the frames are, as given or (without frame times) as found here.
        swapped: (N,) bool numpy, the chosen hypothesis reads the frame's left/right labels exchanged.
    """

    root: torch.Tensor
    transl: torch.Tensor
    loss: torch.Tensor
    spacing: FrameSpacing
    swapped: np.ndarray | None = None


def canonical_rotation(camera: PinholeCamera, dtype=torch.float32) -> torch.Tensor:
    """(3, 3) body-to-world rotation of a person upright in the image and facing the camera.

    Body axes: Z up, -Y forward, X the person's left. Image up is camera -y, the camera looks
    along +z, so the body's up is R^T (0,-1,0) and its forward (-Y) is R^T (0,0,-1).
    """
    R = torch.as_tensor(camera.R, dtype=dtype)
    up = R.T @ torch.tensor([0.0, -1.0, 0.0], dtype=dtype)
    back = R.T @ torch.tensor([0.0, 0.0, 1.0], dtype=dtype)
    left = torch.linalg.cross(back, up)
    return torch.stack([left, back, up], dim=1)


def torso_depth_and_centre(points: np.ndarray, rest_kp: np.ndarray, fy: float, min_conf: float = 0.3):
    """Per frame: camera depth from the torso length, and the torso centre in pixels.

    Args:
        points: (N, 23, 3) detections; rest_kp: (23, 3) model keypoints in the rest pose.
    Returns:
        depth (N,), centre (N, 2), ok (N,) bool (frames with all four torso points).
    """
    conf = points[:, list(SHOULDERS + HIPS), 2]
    ok = (conf > min_conf).all(1)
    sh = points[:, list(SHOULDERS), :2].mean(1)
    hp = points[:, list(HIPS), :2].mean(1)
    length_px = np.linalg.norm(sh - hp, axis=1)
    ok &= length_px > 2.0
    length_3d = np.linalg.norm(rest_kp[list(SHOULDERS)].mean(0) - rest_kp[list(HIPS)].mean(0))
    depth = fy * length_3d / np.maximum(length_px, 1e-6)
    centre = 0.5 * (sh + hp)
    if not ok.any():
        raise InputError("no frame shows both shoulders and both hips; cannot place the body")
    idx = np.arange(len(points))
    good = idx[ok]
    nearest = good[np.abs(idx[:, None] - good[None, :]).argmin(1)]
    return depth[nearest], centre[nearest], ok


def _choose_sequence(loss: torch.Tensor, R: torch.Tensor, switch_weight: torch.Tensor) -> torch.Tensor:
    """Viterbi over frames: (N, K) losses, (N, K, 3, 3) rotations, (N-1,) cost of a squared turn
    between each pair of neighbours -> (N,) chosen hypotheses."""
    N, K = loss.shape
    cost = loss[0].clone()
    back = torch.zeros(N, K, dtype=torch.long)
    for t in range(1, N):
        rel = torch.einsum("jab,kac->jkbc", R[t - 1], R[t])  # R_prev^T R_cur
        cos = ((rel.diagonal(dim1=-2, dim2=-1).sum(-1) - 1) / 2).clamp(-1, 1)
        turn = torch.acos(cos) ** 2
        total = cost[:, None] + switch_weight[t - 1] * turn  # (j, k)
        cost, back[t] = total.min(0)
        cost = cost + loss[t]
    path = torch.zeros(N, dtype=torch.long)
    path[-1] = cost.argmin()
    for t in range(N - 1, 0, -1):
        path[t - 1] = back[t, path[t]]
    return path


def fit_global(points: np.ndarray, camera: PinholeCamera, rest_kp: torch.Tensor, *, hypotheses: int,
               iterations: int, lr: float, scale: float, sigma: float, switch_weight: float,
               spacing: FrameSpacing | None = None, control=None,
               evidence: HeadingEvidence | None = None, turn_aware: bool = True) -> GlobalInit:
    """Rigid fit of the rest-pose body to each frame's torso and head keypoints.

    Args:
        points: (N, 23, 3) detections; rest_kp: (23, 3) rest keypoints (root at the origin).
        scale, sigma: keypoint loss units (see :func:`keypoint_loss`).
        spacing: how far apart the frames are; None when the capture does not say (no frame times,
            not unordered): then the headings are chosen as for a video, the heading changes
            between them give the gaps, and the headings are chosen again with those gaps.
        evidence: the front/back choice's costs; None fits the labels as given only.
        turn_aware: a clip with frame times whose person turns faster than the temporal weights
            expect gets larger gaps there (:func:`frame_spacing.with_turn_speed`).
    """
    dtype = rest_kp.dtype
    N, Y = points.shape[0], max(1, hypotheses)
    labels = (False, True) if evidence is not None else (False,)
    K = Y * len(labels)
    swapped = torch.tensor([s for s in labels for _ in range(Y)])
    depth, centre, _ = torso_depth_and_centre(points, rest_kp.cpu().numpy(), camera.fy)
    Rcam = torch.as_tensor(camera.R, dtype=dtype)
    tcam = torch.as_tensor(camera.t, dtype=dtype)
    d = torch.as_tensor(depth, dtype=dtype)
    c = torch.as_tensor(centre, dtype=dtype)
    xc = torch.stack([(c[:, 0] - camera.cx) / camera.fx * d, (c[:, 1] - camera.cy) / camera.fy * d, d], -1)
    torso_world = (xc - tcam) @ Rcam  # R^T (xc - t)
    R0 = canonical_rotation(camera, dtype) @ yaw_matrix(yaw_candidates(Y, dtype).repeat(len(labels)))  # (K, 3, 3)
    R0 = R0[None].expand(N, K, 3, 3).contiguous()
    torso_rest = rest_kp[list(SHOULDERS + HIPS)].mean(0)
    t0 = torso_world[:, None] - R0 @ torso_rest
    delta = torch.zeros(N, K, 3, dtype=dtype, requires_grad=True)
    transl = t0.clone().requires_grad_(True)
    given = torch.as_tensor(points, dtype=dtype)
    det = torch.stack([given[:, MIRROR_INDEX] if s else given for s in swapped.tolist()], 1)  # (N, K, 23, 3)
    w = torch.zeros(rest_kp.shape[0], dtype=dtype)
    for k, v in GLOBAL_KEYPOINT_WEIGHTS.items():
        w[k] = v
    opt = Adam([delta, transl], lr=lr)

    def losses():
        R = axis_angle_to_matrix(delta) @ R0
        kp = torch.einsum("nkab,jb->nkja", R, rest_kp) + transl[:, :, None]
        return keypoint_loss(camera.project(kp), det, scale, sigma, w), R

    for it in range(iterations):
        opt.zero_grad()
        loss, _ = losses()
        loss.sum().backward()
        opt.step()
        if control is not None and it % 10 == 0:
            control.check()
    with torch.no_grad():
        loss, R = losses()
        norm = loss / w.sum()
        if evidence is not None:
            cos = facing(R, transl, camera)
            norm = norm + sigma ** 2 * heading_costs(cos, face_seen(points), swapped, evidence)
        ar = torch.arange(N)

        def choose(s: FrameSpacing) -> torch.Tensor:
            return _choose_sequence(norm, R, switch_weight * torch.as_tensor(s.switch_weights(), dtype=dtype))

        path = choose(spacing or frame_spacing.dense(N))
        if spacing is None:
            spacing = frame_spacing.from_heading(R[ar, path].numpy())
            path = choose(spacing)
        elif spacing.source == "times" and turn_aware:  # a brisk turn is smoothed as frames further apart
            faster = frame_spacing.with_turn_speed(spacing, R[ar, path].numpy())
            if not np.array_equal(faster.gaps, spacing.gaps):
                spacing = faster
                path = choose(spacing)
        return GlobalInit(root=R[ar, path], transl=transl[ar, path].detach(), loss=loss[ar, path], spacing=spacing,
                          swapped=swapped[path].numpy())
