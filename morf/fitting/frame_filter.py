"""The automatic frame filter: frames whose fit is unreliable are kept out of training.

The paper's supplement describes "a simple heuristic"; this one flags a frame when any of these
holds, each judged against the sequence itself so that it adapts to resolution and detector:

* detection failure: no person, or fewer than ``min_keypoints`` confident keypoints;
* keypoint residual: the fit misses the detections by far more than it usually does;
* silhouette: the body's silhouette overlaps the person mask poorly (when masks exist);
* twisted body: the fitted pelvis is turned from the shoulders by more than a spine allows
  (``max_twist_deg``, :mod:`morf.fitting.twist`): the fit explained the keypoints with an
  impossible body, whatever its residual;
* joint limits: a fitted bone lies far outside its range of motion (``limit_excess_deg``,
  :mod:`morf.fitting.pose_prior`);
* pose jump: the pose differs sharply from BOTH neighbouring frames (a one-frame glitch; a
  real fast motion changes the pose towards one neighbour and away from the other less often).
  Only between frames that are neighbours in time (``neighbours``): the views of a photo set,
  or frames seconds apart, may differ as much as they like.

Reasons are short human sentences stored in PROJECT/fits/filter.json.
"""

from __future__ import annotations

import numpy as np

from morf.fitting.config import FilterConfig


def pose_change_deg(root: np.ndarray, body: np.ndarray, worst: int = 3) -> np.ndarray:
    """(N-1,) rotation change between adjacent frames: mean of the ``worst`` largest per-bone
    changes, degrees (one wrong limb moves two or three bones; a mean over all would dilute it).

    Args:
        root: (N, 3, 3) root rotations; body: (N, B, 3) body-bone axis-angles.
    """
    if len(root) < 2:
        return np.zeros(0)
    rel = np.einsum("nba,nbc->nac", root[:-1], root[1:])
    root_angle = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    body_angle = np.linalg.norm(body[1:] - body[:-1], axis=-1)  # (N-1, B)
    per_bone = np.concatenate([root_angle[:, None], body_angle], axis=1)
    k = min(worst, per_bone.shape[1])
    return np.degrees(np.sort(per_bone, axis=1)[:, -k:].mean(1))


def limit_excess(excess_deg: np.ndarray, bones: tuple[str, ...]) -> tuple[np.ndarray, list[str]]:
    """Per frame, the largest excess over joint limits (degrees) and the bone that has it, from
    (N, B) excesses (``JointLimitPrior.excess_deg``) of the bones named ``bones``."""
    worst = excess_deg.argmax(1)
    return excess_deg.max(1), [bones[int(b)] for b in worst]


def filter_frames(*, residual_px: np.ndarray, confident: np.ndarray, detected: np.ndarray,
                  iou: np.ndarray | None, change_deg: np.ndarray, image_height: int,
                  cfg: FilterConfig, twist_deg: np.ndarray | None = None,
                  limits: tuple[np.ndarray, list[str]] | None = None,
                  neighbours: np.ndarray | None = None) -> dict[int, str]:
    """Frames to reject with the reason.

    Args:
        residual_px: (N,) keypoint residual per frame (the worst few keypoints); confident: (N,) number of confident keypoints;
        detected: (N,) bool; iou: (N,) silhouette IoU or None; change_deg: (N-1,) from
        :func:`pose_change_deg`; twist_deg: (N,) pelvis-shoulder twist or None; limits: per frame
        the largest joint-limit excess in degrees and its bone (:func:`limit_excess`), or None;
        neighbours: (N-1,) bool, frame i and i+1 are close in time (default: all are).
    """
    N = len(residual_px)
    rejected: dict[int, str] = {}
    valid = detected & (confident >= cfg.min_keypoints)
    for i in np.flatnonzero(~valid):
        rejected[int(i)] = "no person detected" if not detected[i] else f"only {int(confident[i])} confident keypoints"
    if not valid.any():
        return rejected
    med_res = float(np.median(residual_px[valid]))
    res_limit = max(cfg.residual_factor * med_res, cfg.residual_min_px * image_height)
    if iou is not None and np.isfinite(iou[valid]).any():
        med_iou = float(np.nanmedian(iou[valid]))
        iou_limit = med_iou - cfg.iou_drop
    else:
        med_iou, iou_limit = None, None
    near = np.ones(len(change_deg), bool) if neighbours is None else np.asarray(neighbours, bool)
    med_change = float(np.median(change_deg[near])) if near.any() else 0.0
    jump_limit = max(cfg.jump_factor * med_change, cfg.jump_min_deg)
    for i in np.flatnonzero(valid):
        i = int(i)
        if twist_deg is not None and twist_deg[i] > cfg.max_twist_deg:
            rejected[i] = (f"body twisted {twist_deg[i]:.0f} deg between pelvis and shoulders "
                           f"(limit {cfg.max_twist_deg:.0f})")
        elif limits is not None and limits[0][i] > cfg.limit_excess_deg:
            rejected[i] = f"{limits[1][i]} {limits[0][i]:.0f} deg beyond its joint limits"
        elif residual_px[i] > res_limit:
            rejected[i] = f"keypoint residual {residual_px[i]:.0f} px (median {med_res:.0f})"
        elif iou_limit is not None and np.isfinite(iou[i]) and iou[i] < iou_limit:
            rejected[i] = f"silhouette IoU {iou[i]:.2f} (median {med_iou:.2f})"
        elif (0 < i < N - 1 and near[i - 1] and near[i] and change_deg[i - 1] > jump_limit
              and change_deg[i] > jump_limit):
            rejected[i] = f"pose jump {min(change_deg[i - 1], change_deg[i]):.0f} deg (median {med_change:.1f})"
    return rejected
