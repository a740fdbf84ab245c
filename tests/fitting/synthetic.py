"""Tiny synthetic fitting inputs made directly from the body model (no renderer needed)."""

from __future__ import annotations

import math

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.camera import PinholeCamera
from morf.capture.project import CaptureProject, Keypoints2D
from morf.fitting.evaluate import silhouettes
from morf.fitting.inputs import FitInputs, downsample_mask, raster_size

SHAPE = torch.tensor([[0.55, 0.45, 0.5, 0.55, 0.5, 0.5]])


def turning_poses(model, n: int, seed: int = 0, turn: float = 2 * math.pi, cycles: float = 1.0) -> BodyPose:
    """n frames of a person turning by ``turn`` in place, limbs swinging ``cycles`` times."""
    rng = np.random.default_rng(seed)
    rot = torch.zeros(n, len(model.bone_names), 3)
    t = torch.linspace(0, 1, n)
    rot[:, 0, 2] = t * turn
    phase = float(rng.uniform(0, 2 * math.pi))
    for name, axis, amp in (("upperarm01.L", 1, -0.5), ("upperarm01.R", 1, 0.5), ("lowerarm01.L", 0, -0.4),
                            ("lowerarm01.R", 0, -0.3), ("upperleg01.L", 0, -0.25), ("lowerleg01.L", 0, 0.4),
                            ("spine02", 0, 0.15), ("neck01", 2, 0.3)):
        rot[:, model.bone_index(name), axis] = amp * (0.5 + 0.5 * torch.sin(2 * math.pi * cycles * t + phase))
    transl = torch.zeros(n, 3)
    transl[:, 0] = 0.05 * torch.sin(2 * math.pi * t)
    return BodyPose(rot, transl)


def make_inputs(model, pose: BodyPose, shape: torch.Tensor, size: int = 256, noise_px: float = 1.0,
                sil_res: int = 96, eval_res: int = 128, seed: int = 0):
    """FitInputs with projected keypoints (+ noise) and masks rendered from the ground truth (the
    keypoints' source is "ground_truth": no detector's guesses among them)."""
    cam = PinholeCamera.look_at(size, size, 40.0, eye=(0.0, -3.4, 0.0), target=(0.0, 0.0, -0.05))
    with torch.no_grad():
        out = model(pose, shape)
        kp = cam.project(out.keypoints3d).numpy()
        full = silhouettes(out.vertices, model.faces, cam, 1.0, size, size)
    rng = np.random.default_rng(seed)
    pts = np.concatenate([kp + rng.normal(0, noise_px, kp.shape), np.ones(kp.shape[:2] + (1,))], -1).astype(np.float32)
    sw, sh, _ = raster_size(size, size, sil_res)
    ew, eh, _ = raster_size(size, size, eval_res)
    masks = np.stack([downsample_mask(m, sw, sh) for m in full])
    masks_eval = np.stack([downsample_mask(m, ew, eh) >= 0.5 for m in full])
    n = pose.batch_size
    return FitInputs(pts, np.ones(n, bool), cam, masks, sh / size, masks_eval, eh / size,
                     keypoint_source=np.full(n, "ground_truth")), out


def write_project(root, model, n=8, bad=4):
    """A 256 px capture project of ``n`` frames of the body turning, masks from the body itself,
    and frame ``bad`` with the arms' keypoints confused (the frame filter rejects it)."""
    pose = turning_poses(model, n, turn=np.pi / 2)
    inputs, _ = make_inputs(model, pose, SHAPE, size=256, sil_res=64, eval_res=64)
    points = inputs.keypoints.copy()
    # the detector confused the arms in one frame
    points[bad, [7, 8, 9, 10]] = points[bad, [8, 7, 10, 9]]
    points[bad, [7, 8, 9, 10], :2] += (points[bad, [7, 8, 9, 10], :2] - points[bad, [5, 6, 5, 6], :2]) * 0.8
    project = CaptureProject.create(root, num_frames=n, width=256, height=256, fps=30.0, source={"kind": "test"},
                                    camera=inputs.camera)
    with torch.no_grad():
        masks = silhouettes(model(pose, SHAPE).vertices, model.faces, inputs.camera, 1.0, 256, 256)
    for i in range(n):
        project.save_frame(i, np.full((256, 256, 3), 120, np.uint8))
        project.save_mask(i, masks[i])
    project.save_keypoints(Keypoints2D(points, np.ones(n, bool), np.full(n, "ground_truth")))
    return project
