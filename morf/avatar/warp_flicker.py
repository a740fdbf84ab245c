"""Flicker that forgives misregistration: the temporal warping error (Lai et al., "Learning Blind
Video Temporal Consistency", ECCV 2018).

``temporal`` (:func:`morf.avatar.metrics.temporal_flicker`) compares the render's change between
two frames with the real frames' change at the same pixels. A render that is steady but a few
pixels off the real frames (the fit's error) is charged there in proportion to its detail: a
sharp print a pixel or two off scores as more flicker than the same print blurred. This score
asks only whether the render moves with the person: the real frames' optical flow from frame t+1
back to frame t (DIS, OpenCV) warps each frame t onto frame t+1, and the score is the mean
absolute difference between frame t+1 and the warped frame t, over the real person where the flow
is consistent forwards and backwards (the usual occlusion test). A constant offset between render
and real, or a texture a steady pixel off, costs nothing; texels that swim or pop from one frame
to the next do. The real frames' own warping error (flow errors, light changes, the person's own
cloth motion) is reported beside it for scale: what the flow cannot explain in the real video. It
is no strict floor: a render smoother than the video (no sensor noise, no cloth swinging) can
score under it.
"""

from __future__ import annotations

import cv2
import numpy as np

from morf.io.images import grey_uint8


def _remap(image: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """``image`` sampled at p + flow(p) (bilinear, edges replicated)."""
    h, w = flow.shape[:2]
    gx, gy = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    return cv2.remap(np.ascontiguousarray(image, np.float32), gx + flow[..., 0], gy + flow[..., 1],
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def consistent(back: np.ndarray, fwd: np.ndarray) -> np.ndarray:
    """(H, W) bool: where the flow from frame t+1 to t (``back``) and the flow from t to t+1
    (``fwd``, read where ``back`` lands) cancel, within 1 % of their squared lengths + 0.5 px^2."""
    fwd_at = _remap(fwd, back)
    diff = ((back + fwd_at) ** 2).sum(-1)
    return diff < 0.01 * ((back ** 2).sum(-1) + (fwd_at ** 2).sum(-1)) + 0.5


def warping_errors(renders: np.ndarray, reals: np.ndarray, masks: np.ndarray) -> tuple[float, float] | None:
    """(render, real): the mean over consecutive pairs of the warping error of the renders and of
    the real frames, both warped by the real frames' flow. renders, reals: (T, H, W, 3) in [0, 1]
    over the same backdrop; masks: (T, H, W) the real person. None with fewer than two frames or
    no pair with a consistent person pixel."""
    if len(reals) < 2:
        return None
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    out_r, out_g = [], []
    for t in range(len(reals) - 1):
        g0, g1 = grey_uint8(reals[t]), grey_uint8(reals[t + 1])
        back, fwd = dis.calc(g1, g0, None), dis.calc(g0, g1, None)
        region = consistent(back, fwd) & (masks[t + 1] > 0.5)
        if not region.any():
            continue
        for seq, acc in ((renders, out_r), (reals, out_g)):
            err = np.abs(seq[t + 1].astype(np.float32) - _remap(seq[t], back)).mean(-1)
            acc.append(float(err[region].mean()))
    if not out_r:
        return None
    return float(np.mean(out_r)), float(np.mean(out_g))
