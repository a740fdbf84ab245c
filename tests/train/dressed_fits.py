"""Body fits with clothing offsets on a synthetic capture: its ground-truth poses and shape, with
smooth outward offsets that grow towards the feet (as a skirt or loose trousers would)."""

from __future__ import annotations

import numpy as np
import torch

from morf.fitting.fits_io import BodyFits, save_fits
from morf.synth.ground_truth import load_ground_truth


def height_offsets(body_model, low: float = 0.01, high: float = 0.05) -> np.ndarray:
    """(V,) float32 offsets from ``high`` metres at the lowest rest vertex to ``low`` at the top."""
    with torch.no_grad():
        z = body_model.rest(body_model.default_shape())["rest_vertices"][0, :, 2].cpu().numpy()
    t = (z.max() - z) / (z.max() - z.min())
    return (low + (high - low) * t).astype(np.float32)


def write_dressed_fits(project, body_model, offsets: np.ndarray) -> BodyFits:
    """Write ``project``'s fits.npz: the ground truth's poses and shape plus ``offsets`` (V,)."""
    gt = load_ground_truth(project)
    n = len(gt.rotvecs)
    zeros = np.zeros(n, np.float32)
    fits = BodyFits(rotvecs=gt.rotvecs.astype(np.float32), transl=gt.transl.astype(np.float32),
                    shape=np.asarray(gt.shape, np.float32).reshape(-1, gt.shape.shape[-1])[:1],
                    keypoint_residual_px=zeros, keypoint_worst_px=zeros, silhouette_iou=zeros,
                    projected_keypoints=np.zeros((n, 23, 2), np.float32), config={},
                    silhouette_iou_body=zeros, offsets=offsets.astype(np.float32))
    project.fits_path.parent.mkdir(parents=True, exist_ok=True)
    save_fits(project.fits_path, fits)
    return fits
