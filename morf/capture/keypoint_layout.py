"""The one 2D keypoint layout used inside MoRF: COCO-17 followed by 6 foot points (23).

The foot points alternate left/right (big toes, small toes, heels). It is exactly the order of Anny's COCO regressor, so 2D detections and the body model's
projected keypoints line up index by index. Detector layouts are mapped onto it here.
"""

from __future__ import annotations

import numpy as np

KEYPOINT_NAMES = (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
    "left_wrist", "right_wrist", "left_hip", "right_hip",
    "left_knee", "right_knee", "left_ankle", "right_ankle",
    "left_big_toe", "right_big_toe", "left_small_toe", "right_small_toe", "left_heel", "right_heel",
)
NUM_KEYPOINTS = len(KEYPOINT_NAMES)


def _mirror_index() -> np.ndarray:
    """(23,) index of each keypoint's left/right partner (itself for the nose)."""
    index = np.arange(NUM_KEYPOINTS)
    for i, name in enumerate(KEYPOINT_NAMES):
        for a, b in (("left_", "right_"), ("right_", "left_")):
            if name.startswith(a):
                index[i] = KEYPOINT_NAMES.index(b + name[len(a):])
    return index


# Each keypoint's mirror partner: a mirrored frame's points (mirror_average) and a detector's
# exchanged left/right labels (the fit's front/back choice) are undone with it.
MIRROR_INDEX = _mirror_index()

# Skeleton edges for drawing overlays.
SKELETON = (
    (5, 6), (5, 7), (7, 9), (6, 8), (8, 10), (5, 11), (6, 12), (11, 12),
    (11, 13), (13, 15), (12, 14), (14, 16), (0, 1), (0, 2), (1, 3), (2, 4),
    (15, 17), (15, 19), (15, 21), (16, 18), (16, 20), (16, 22),
)

# MediaPipe BlazePose 33 landmarks -> our index (-1: MediaPipe has no small toe).
MEDIAPIPE_TO_OURS = {
    0: 0, 2: 1, 5: 2, 7: 3, 8: 4, 11: 5, 12: 6, 13: 7, 14: 8, 15: 9, 16: 10,
    23: 11, 24: 12, 25: 13, 26: 14, 27: 15, 28: 16, 31: 17, 32: 18, 29: 21, 30: 22,
}

# OpenPose BODY_25 -> our index.
BODY25_TO_OURS = {
    0: 0, 16: 1, 15: 2, 18: 3, 17: 4, 5: 5, 2: 6, 6: 7, 3: 8, 7: 9, 4: 10,
    12: 11, 9: 12, 13: 13, 10: 14, 14: 15, 11: 16, 19: 17, 20: 19, 21: 21, 22: 18, 23: 20, 24: 22,
}
# OpenPose COCO-18 (older JSON files without feet) -> our index.
OPENPOSE_COCO18_TO_OURS = {
    0: 0, 15: 1, 14: 2, 17: 3, 16: 4, 5: 5, 2: 6, 6: 7, 3: 8, 7: 9, 4: 10,
    11: 11, 8: 12, 12: 13, 9: 14, 13: 15, 10: 16,
}


def remap(points: np.ndarray, mapping: dict[int, int]) -> np.ndarray:
    """(N, S, 3) source keypoints (x, y, confidence) -> (N, 23, 3); missing points get conf 0."""
    points = np.asarray(points, dtype=np.float32)
    out = np.zeros((points.shape[0], NUM_KEYPOINTS, 3), dtype=np.float32)
    for src, dst in mapping.items():
        if src < points.shape[1]:
            out[:, dst] = points[:, src]
    return out
