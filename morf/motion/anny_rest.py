"""What retargeting needs to know about the target body: its zero-pose skeleton and feet."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

FOOT_KEYPOINTS = tuple(range(17, 23))  # big toe, small toe, heel of both feet (COCO-17 + 6)


@dataclass(frozen=True)
class TargetRest:
    """Anny in its zero pose (the A-pose every rotation is relative to) for one shape.

    Fields:
        names: J bone names; parents: J parent indices (parents before children).
        heads: (J, 3) float64 bone heads, metres, root at the origin.
        leg_length: hip socket -> knee -> ankle, metres (mean of both legs).
        foot_points: (2, 3) indices into keypoints3d of the left and right foot points.
        foot_height: height of the lowest foot point below the root, metres (positive).
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    heads: np.ndarray
    leg_length: float
    foot_points: tuple[tuple[int, ...], tuple[int, ...]]
    foot_height: float

    def index(self, name: str) -> int:
        return self.names.index(name)


@torch.no_grad()
def target_rest(model, shape: torch.Tensor | None = None) -> TargetRest:
    """Evaluate ``model`` (Anny) in its zero pose for ``shape`` (1, 6) (default: its default shape)."""
    shape = model.default_shape() if shape is None else shape[:1]
    out = model(model.zero_pose(1), shape)
    heads = out.joints[0].double().cpu().numpy()
    kp = out.keypoints3d[0].double().cpu().numpy()
    names = tuple(model.bone_names)
    parents = tuple(int(p) for p in model.bone_parents)
    if any(p >= c for c, p in enumerate(parents) if c > 0):
        raise ValueError("retargeting expects every bone's parent to come before it")
    idx = names.index
    leg = np.mean([np.linalg.norm(heads[idx(f"upperleg01.{s}")] - heads[idx(f"lowerleg01.{s}")])
                   + np.linalg.norm(heads[idx(f"lowerleg01.{s}")] - heads[idx(f"foot.{s}")]) for s in "LR"])
    # Sides by position (the person's left is +X) rather than by index order.
    left = tuple(k for k in FOOT_KEYPOINTS if kp[k, 0] > 0)
    right = tuple(k for k in FOOT_KEYPOINTS if kp[k, 0] <= 0)
    foot_height = float(heads[0, 2] - kp[list(FOOT_KEYPOINTS), 2].min())
    return TargetRest(names, parents, heads, float(leg), (left, right), foot_height)
