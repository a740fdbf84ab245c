"""Face mesh and hand landmarks of every frame, from the models the MediaPipe wheel ships
(``mediapipe==0.10.14``: ``face_landmark_with_attention`` with 478 points, ``hand_landmark_full``
with 21 points a hand), and OpenPose's face and hand points read as the same evidence.

A head of 30-60 px in a full frame is too small for MediaPipe's face and palm detectors, so each
is run on a square crop around the body keypoints (the head around the nose, eyes and ears; each
hand beyond its wrist, along the forearm), enlarged to ``CROP_SIDE`` pixels. A hand is taken
as the left or right one by which body wrist it lies at, not by MediaPipe's handedness label
(which assumes a mirrored selfie image and is often wrong on small hands).

Stored beside ``keypoints.npz`` as ``landmarks_face_hands.npz`` (:data:`LANDMARKS_FILE`):
face (N, 478, 3), hand_left, hand_right (N, 21, 3), x and y in frame pixels (MoRF's pixel
centres at +0.5) and a confidence (0: not found).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.errors import ProjectError

LANDMARKS_FILE = "landmarks_face_hands.npz"
FACE_POINTS, HAND_POINTS, IBUG_POINTS = 478, 21, 70  # MediaPipe face mesh; hands; OpenPose face
CROP_SIDE = 256
# The few face points the fit uses, as indices of each face layout (their mean): the subject's
# right and left eye (pupil), the nose tip, the mouth's centre, the chin.
FACE_ANCHORS = ("right_eye", "left_eye", "nose_tip", "mouth", "chin")
MEDIAPIPE_FACE_ANCHORS = ((468,), (473,), (1,), (13, 14), (152,))  # 468-477: the irises (refined landmarks)
IBUG_FACE_ANCHORS = (tuple(range(36, 42)), tuple(range(42, 48)), (30,), (62, 66), (8,))  # OpenPose's 70


@dataclass(frozen=True)
class FaceHandLandmarks:
    """Face and hand landmarks of every frame.

    Fields:
        face: (N, F, 3) float32 x, y in pixels, confidence; F = 478 (MediaPipe) or 70 (OpenPose).
        hand_left, hand_right: (N, 21, 3) float32 the person's own left and right hand, in the
            21-point layout MediaPipe and OpenPose share (wrist, then thumb, index, middle, ring
            and little finger from base to tip, four points each).
        source: "mediapipe" | "openpose".
    """

    face: np.ndarray
    hand_left: np.ndarray
    hand_right: np.ndarray
    source: str

    @property
    def num_frames(self) -> int:
        return int(self.face.shape[0])

    def face_anchors(self) -> np.ndarray:
        """(N, 5, 3) the ``FACE_ANCHORS`` points: means of their layout's points, confidence the
        smallest of theirs."""
        return face_anchors(self.face)


def face_anchors(face: np.ndarray) -> np.ndarray:
    """(N, F, 3) face points in either layout -> (N, 5, 3) ``FACE_ANCHORS``."""
    table = {FACE_POINTS: MEDIAPIPE_FACE_ANCHORS, IBUG_POINTS: IBUG_FACE_ANCHORS}.get(face.shape[1])
    if table is None:
        raise ValueError(f"face landmarks with {face.shape[1]} points: expected {FACE_POINTS} or {IBUG_POINTS}")
    out = np.zeros((face.shape[0], len(table), 3), np.float32)
    for k, idx in enumerate(table):
        pts = face[:, list(idx)]
        out[:, k, :2] = pts[..., :2].mean(1)
        out[:, k, 2] = pts[..., 2].min(1)
    return out


def save_landmarks(project_root: str | Path, lm: FaceHandLandmarks) -> Path:
    """Write ``PROJECT/landmarks_face_hands.npz`` atomically."""
    from morf.io import save_npz

    path = Path(project_root) / LANDMARKS_FILE
    save_npz(path, face=lm.face.astype(np.float32), hand_left=lm.hand_left.astype(np.float32),
             hand_right=lm.hand_right.astype(np.float32), source=np.array(lm.source))
    return path


def load_landmarks(project) -> FaceHandLandmarks | None:
    """The project's face and hand evidence: its detected landmarks, else the OpenPose face and
    hand points ingest imported (``keypoints_hands_face.npz``), else None."""
    from morf.io import load_npz

    root = Path(project.root)
    if (root / LANDMARKS_FILE).is_file():
        d = load_npz(root / LANDMARKS_FILE)
        lm = FaceHandLandmarks(d["face"], d["hand_left"], d["hand_right"], str(d["source"]))
    elif (root / "keypoints_hands_face.npz").is_file():
        d = load_npz(root / "keypoints_hands_face.npz")
        lm = FaceHandLandmarks(d["face"], d["hand_left"], d["hand_right"], "openpose")
    else:
        return None
    if lm.num_frames != project.num_frames:
        raise ProjectError(f"{root} has face and hand landmarks of {lm.num_frames} frames for {project.num_frames} "
                        "frames; detect them again (morf.capture.landmarks_detect.detect_project_landmarks)")
    return lm
