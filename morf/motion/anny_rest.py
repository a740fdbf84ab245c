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


class FootPointEvaluator:
    """The six foot keypoints of posed frames, skinning only the vertices they are regressed from
    (about 1,600 of Anny's 13,718) with the shaped rest model computed once.

    Equivalent to ``model(pose, shape).keypoints3d[:, 17:23]`` (checked by the tests); models
    without Anny's ``rest`` / ``pose_to_deltas`` fall back to the full forward pass.
    """

    def __init__(self, model, shape: torch.Tensor | None = None):
        self.model = model
        self.shape = model.default_shape() if shape is None else shape[:1]
        self.fast = all(hasattr(model, a) for a in ("rest", "pose_to_deltas", "anny", "keypoint_regressor"))
        if self.fast:
            with torch.no_grad():
                reg = model.keypoint_regressor[list(FOOT_KEYPOINTS)]
                cols = torch.nonzero((reg != 0).any(0)).flatten()
                rest = model.rest(self.shape)
                self.regressor = reg[:, cols]
                self.weights = model.dense_weights[cols]
                self.rest_vertices = rest["rest_vertices"][:, cols]
                self.rest_poses = rest["rest_bone_poses"]

    @torch.no_grad()
    def __call__(self, pose) -> torch.Tensor:
        """(B, 6, 3) foot points for a :class:`~morf.body.model.BodyPose` batch."""
        if not self.fast:
            return self.model(pose, self.shape).keypoints3d[:, list(FOOT_KEYPOINTS)]
        from morf.body.lbs import linear_blend_skinning

        B = pose.batch_size
        rest_poses = self.rest_poses.expand(B, -1, -1, -1)
        transforms, _ = self.model.anny.get_bone_transforms(self.model.pose_to_deltas(pose), rest_poses)
        verts = linear_blend_skinning(self.rest_vertices.expand(B, -1, -1), self.weights, transforms)
        return torch.einsum("kv,bvc->bkc", self.regressor, verts)
