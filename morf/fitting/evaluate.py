"""Per-frame quality of a fit with the full body mesh: keypoint residual, silhouette IoU."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.camera import PinholeCamera
from morf.fitting.losses import keypoint_residual_px, worst_keypoint_residual_px
from morf.fitting.offsets import dressed_vertices
from morf.fitting.twist import twist_deg
from morf.raster.soft_silhouette import front_facing, hard_coverage


@dataclass(frozen=True)
class FitEvaluation:
    """Fields:
        keypoint_residual_px: (N,) confidence-weighted mean distance, detected vs fitted keypoints.
        silhouette_iou: (N,) IoU of the fitted surface's silhouette (the body plus clothing offsets,
            when there are any) and the person mask (NaN without masks).
        silhouette_iou_body: (N,) the same for the body alone (equal to silhouette_iou without offsets).
        keypoint_worst_px: (N,) mean of the 3 largest keypoint distances (what the filter judges).
        projected_keypoints: (N, 23, 2) fitted keypoints in pixels.
        twist_deg: (N,) pelvis-shoulder twist of the fitted body, degrees (twist.py).
    """

    keypoint_residual_px: np.ndarray
    keypoint_worst_px: np.ndarray
    silhouette_iou: np.ndarray
    projected_keypoints: np.ndarray
    silhouette_iou_body: np.ndarray
    twist_deg: np.ndarray


def posed_chunks(model, rotvecs: torch.Tensor, transl: torch.Tensor, shape: torch.Tensor,
                 chunk: int = 32) -> Iterator[tuple[slice, "object"]]:
    """Yield (frames, BodyOutput) of the full model over all frames, ``chunk`` at a time."""
    N = rotvecs.shape[0]
    with torch.no_grad():
        for s in range(0, N, chunk):
            sl = slice(s, min(N, s + chunk))
            sh = shape if shape.shape[0] == 1 else shape[sl]
            yield sl, model(BodyPose(rotvecs[sl], transl[sl]), sh)


def silhouettes(vertices: torch.Tensor, faces: torch.Tensor, camera: PinholeCamera, scale: float,
                width: int, height: int, front_only: bool = False) -> np.ndarray:
    """(B, V, 3) world vertices -> (B, height, width) bool hard silhouettes at ``scale``.

    Drawn by OpenGL (:func:`morf.raster.gl_silhouette.silhouettes_gl`: 12x faster at 512 px);
    where no GL context can be made, by the same per-pixel test in torch (the two differ on at
    most a few outline pixels of a frame, where a pixel centre lies on a triangle edge).
    ``front_only`` draws only the triangles facing the camera."""
    from morf.raster.gl_context import GLUnavailable

    try:
        from morf.raster.gl_silhouette import silhouettes_gl

        return silhouettes_gl(vertices, faces, camera, scale, width, height, front_only=front_only)
    except GLUnavailable:
        pix = camera.project(vertices) * scale
        tri = pix[:, faces]
        cam_v = camera.world_to_camera(vertices)
        keep = (cam_v[..., 2] > 1e-3)[:, faces].all(-1)
        if front_only:
            keep = keep & front_facing(cam_v, faces)
        return hard_coverage(tri, keep, height, width).cpu().numpy()


def iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) IoU of boolean masks (N, H, W); 1 where both are empty."""
    inter = (a & b).sum((1, 2))
    union = (a | b).sum((1, 2))
    return np.where(union > 0, inter / np.maximum(union, 1), 1.0)


def evaluate_fit(model, rotvecs: torch.Tensor, transl: torch.Tensor, shape: torch.Tensor,
                 keypoints: np.ndarray, camera: PinholeCamera, masks_eval: np.ndarray | None,
                 eval_scale: float, min_confidence: float = 0.3, offsets: torch.Tensor | None = None) -> FitEvaluation:
    """Evaluate a fit. ``keypoints``: (N, 23, 3) detections; ``masks_eval``: (N, h, w) bool or None;
    ``offsets``: optional (V,) clothing offsets (``offsets.py``)."""
    N = rotvecs.shape[0]
    proj = np.zeros((N, keypoints.shape[1], 2), np.float32)
    ious = np.full(N, np.nan, np.float32)
    ious_body = ious.copy()
    twist = np.zeros(N, np.float32)
    faces = model.faces
    for sl, out in posed_chunks(model, rotvecs, transl, shape):
        proj[sl] = camera.project(out.keypoints3d).cpu().numpy()
        twist[sl] = twist_deg(out.keypoints3d.cpu().numpy())
        if masks_eval is not None:
            h, w = masks_eval.shape[1:]
            sil = silhouettes(out.vertices, faces, camera, eval_scale, w, h)
            ious_body[sl] = iou(sil, masks_eval[sl])
            if offsets is not None:
                sh = shape if shape.shape[0] == 1 else shape[sl]
                with torch.no_grad():
                    dressed = dressed_vertices(model, out, sh, offsets)
                sil = silhouettes(dressed, faces, camera, eval_scale, w, h)
            ious[sl] = iou(sil, masks_eval[sl])
    p, k = torch.as_tensor(proj), torch.as_tensor(keypoints)
    res = keypoint_residual_px(p, k, min_confidence).numpy().astype(np.float32)
    worst = worst_keypoint_residual_px(p, k, 3, min_confidence).numpy().astype(np.float32)
    return FitEvaluation(res, worst, ious, proj, ious_body, twist)
