"""Where people look: the head and the hands of every training frame, for training crops centred on them.

At the `cpu` preset's 256 px working side the face is about 30 px high and a hand about 20 px;
random crops of the zoomed frames (``zoom_resolution``) show the face in only some of the steps.
With ``TrainConfig.detail_every`` some steps take their crops from the zoomed frames centred on
the head or on a hand instead, so the renderer sees those parts at the side the player draws
them in a fixed share of the steps. The centres come from the body fits (the projected head
keypoints and the middle of each hand), not from the images, so they cost one body evaluation
per frame and follow the same fit the rasterization does.
"""

from __future__ import annotations

import numpy as np
import torch

from morf.camera import PinholeCamera

DETAIL_REGIONS = ("head", "left hand", "right hand")
# Head: the mean of COCO nose, eyes and ears, raised by this share of the crop towards the top of
# the head so that hair and chin both fall inside it; hands: between the wrist and the middle
# finger's first joint.
_HAND_BONES = (("wrist.L", "finger3-1.L"), ("wrist.R", "finger3-1.R"))


def detail_points(model, rotvecs: np.ndarray, transl: np.ndarray, shape: np.ndarray, chunk: int = 32) -> np.ndarray:
    """(N, 3, 3) float32 world positions of the head, the left hand and the right hand per frame."""
    from morf.body import BodyPose

    bones = [[model.bone_index(name) for name in pair] for pair in _HAND_BONES]
    out = []
    with torch.no_grad():
        for s in range(0, len(rotvecs), chunk):
            body = model(BodyPose(torch.from_numpy(rotvecs[s:s + chunk]).float(),
                                  torch.from_numpy(transl[s:s + chunk]).float()),
                         torch.from_numpy(shape.reshape(1, -1)).float())
            head = body.keypoints3d[:, 0:5].mean(1)
            hands = [body.joints[:, pair].mean(1) for pair in bones]
            out.append(torch.stack([head, *hands], dim=1).float().numpy())
    return np.concatenate(out).astype(np.float32)


def detail_centres(points: np.ndarray, camera: PinholeCamera) -> np.ndarray:
    """(N, R, 2) float32 pixel positions (x, y) in ``camera`` of (N, R, 3) world points."""
    flat = torch.from_numpy(points.reshape(-1, 3)).double()
    px = camera.project(flat).float().numpy()
    return px.reshape(points.shape[0], points.shape[1], 2).astype(np.float32)


def crop_origins(centres: np.ndarray, crop: int, side: int, rng: np.random.Generator,
                 jitter: float = 0.125) -> tuple[np.ndarray, np.ndarray]:
    """(ys, xs) int top-left corners of ``crop``-pixel squares around (B, 2) pixel ``centres`` in a
    ``side``-pixel image, moved by up to ``jitter`` of the crop each way (so the part is not always
    drawn in the crop's middle, where the renderer's receptive field would learn a fixed place for
    it) and clamped to the image."""
    c = np.nan_to_num(np.asarray(centres, np.float64), nan=side / 2)
    shift = rng.uniform(-jitter, jitter, size=c.shape) * crop
    x0 = np.clip(np.round(c[:, 0] + shift[:, 0] - crop / 2), 0, side - crop).astype(np.int64)
    y0 = np.clip(np.round(c[:, 1] + shift[:, 1] - crop / 2), 0, side - crop).astype(np.int64)
    return y0, x0
