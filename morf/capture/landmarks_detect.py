"""Running MediaPipe's face mesh and hand landmark models on crops around the body keypoints
(:mod:`morf.capture.landmarks_face_hands` says why crops and what is stored).

Only the models the wheel ships are used: ``FaceMesh(refine_landmarks=True)`` (478 points,
irises included) and ``Hands(model_complexity=1)``, both with ``static_image_mode`` (every crop
is a different window, as for the pose detector).
"""

from __future__ import annotations

from typing import Callable

import cv2
import numpy as np

from morf.capture.landmarks_face_hands import (CROP_SIDE, FACE_POINTS, HAND_POINTS, FaceHandLandmarks,
                                               save_landmarks)
from morf.errors import MorfError

MIN_BODY_CONFIDENCE = 0.3  # body keypoints a crop is placed by
NOSE, EYES, EARS, SHOULDERS = 0, (1, 2), (3, 4), (5, 6)
WRIST_ELBOW = {"left": (9, 7), "right": (10, 8)}


def head_square(body: np.ndarray) -> tuple[float, float, float] | None:
    """(cx, cy, side) in pixels of the square to look for the face in, from (23, 3) body
    keypoints: centred on the seen face points, 1.2 shoulder widths (or 3 ear-to-ear or eye-to-eye
    widths) across; None without a confident nose or eye."""
    face = [k for k in (NOSE, *EYES, *EARS) if body[k, 2] > MIN_BODY_CONFIDENCE]
    if not any(k in face for k in (NOSE, *EYES)):
        return None
    cx, cy = body[face, :2].mean(0)
    sizes = []
    if all(body[k, 2] > MIN_BODY_CONFIDENCE for k in SHOULDERS):
        sizes.append(1.2 * np.linalg.norm(body[5, :2] - body[6, :2]))
    for a, b, f in ((*EARS, 3.0), (*EYES, 6.0)):
        if body[a, 2] > MIN_BODY_CONFIDENCE and body[b, 2] > MIN_BODY_CONFIDENCE:
            sizes.append(f * np.linalg.norm(body[a, :2] - body[b, :2]))
    return (float(cx), float(cy), float(max(sizes))) if sizes else None


def hand_square(body: np.ndarray, side: str) -> tuple[float, float, float] | None:
    """(cx, cy, side) of the square to look for one hand in: centred a third of a forearm beyond
    the wrist, 1.5 forearms across; None without a confident wrist and elbow."""
    w, e = WRIST_ELBOW[side]
    if body[w, 2] <= MIN_BODY_CONFIDENCE or body[e, 2] <= MIN_BODY_CONFIDENCE:
        return None
    fore = body[w, :2] - body[e, :2]
    length = float(np.linalg.norm(fore))
    if length < 2:
        return None
    c = body[w, :2] + fore / 3
    return float(c[0]), float(c[1]), 1.5 * length


def crop_square(rgb: np.ndarray, square, out: int = CROP_SIDE) -> tuple[np.ndarray, float, float, float]:
    """(out, out, 3) crop of ``square`` = (cx, cy, side) (black outside the image) and the map
    back: frame = crop * scale + (x0, y0), both in continuous coordinates (pixel centres at +0.5,
    as MoRF and MediaPipe's normalised landmarks have them). Returns (crop, x0, y0, scale)."""
    cx, cy, side = square
    scale = side / out
    x0, y0 = cx - side / 2, cy - side / 2
    # OpenCV puts pixel centres on integers: crop pixel i samples frame pixel (i + 0.5) * scale + x0 - 0.5
    bx, by = 0.5 * scale + x0 - 0.5, 0.5 * scale + y0 - 0.5
    M = np.array([[1 / scale, 0, -bx / scale], [0, 1 / scale, -by / scale]], np.float64)
    crop = cv2.warpAffine(rgb, M, (out, out), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    return crop, x0, y0, scale


def _points(landmarks, x0: float, y0: float, scale: float, count: int, confidence: float) -> np.ndarray:
    """MediaPipe's normalised landmarks of a crop -> (count, 3) frame pixels and a confidence."""
    xy = np.array([(p.x, p.y) for p in landmarks.landmark][:count], np.float64) * CROP_SIDE
    out = np.zeros((count, 3), np.float32)
    out[:, 0] = xy[:, 0] * scale + x0
    out[:, 1] = xy[:, 1] * scale + y0
    out[:, 2] = confidence
    return out


class FaceHandsDetector:
    """MediaPipe's face mesh and hands on crops. Not thread-safe; :meth:`close` it (or ``with``)."""

    def __init__(self, min_confidence: float = 0.3):
        from morf.capture.detect_mediapipe import _quiet_native_logs

        try:
            with _quiet_native_logs():
                from mediapipe.python.solutions import face_mesh, hands
        except ImportError as e:
            raise MorfError(f"MediaPipe is not installed ({e}): pip install --no-deps mediapipe==0.10.14") from None
        with _quiet_native_logs():
            self._face = face_mesh.FaceMesh(static_image_mode=True, max_num_faces=1, refine_landmarks=True,
                                            min_detection_confidence=min_confidence)
            self._hands = hands.Hands(static_image_mode=True, max_num_hands=2, model_complexity=1,
                                      min_detection_confidence=min_confidence)
            blank = np.zeros((64, 64, 3), np.uint8)
            self._face.process(blank)  # the graphs start their workers inside the quiet window
            self._hands.process(blank)

    def face(self, rgb: np.ndarray, body: np.ndarray) -> np.ndarray:
        """(478, 3) face landmarks in frame pixels (confidence 1 where found, all 0 otherwise)."""
        square = head_square(body)
        if square is None:
            return np.zeros((FACE_POINTS, 3), np.float32)
        crop, x0, y0, scale = crop_square(rgb, square)
        res = self._face.process(crop)
        if not res.multi_face_landmarks:
            return np.zeros((FACE_POINTS, 3), np.float32)
        return _points(res.multi_face_landmarks[0], x0, y0, scale, FACE_POINTS, 1.0)

    def hand(self, rgb: np.ndarray, body: np.ndarray, side: str) -> np.ndarray:
        """(21, 3) landmarks of the person's ``side`` ("left" | "right") hand: of the hands found
        in its crop, the one whose wrist lies nearest the body's wrist, within half the crop; the
        confidence is MediaPipe's hand score."""
        square = hand_square(body, side)
        none = np.zeros((HAND_POINTS, 3), np.float32)
        if square is None:
            return none
        crop, x0, y0, scale = crop_square(rgb, square)
        res = self._hands.process(crop)
        if not res.multi_hand_landmarks:
            return none
        wrist = body[WRIST_ELBOW[side][0], :2]
        found = [_points(lm, x0, y0, scale, HAND_POINTS, hd.classification[0].score)
                 for lm, hd in zip(res.multi_hand_landmarks, res.multi_handedness)]
        best = min(found, key=lambda p: np.linalg.norm(p[0, :2] - wrist))
        return best if np.linalg.norm(best[0, :2] - wrist) < square[2] / 2 else none

    def detect(self, rgb: np.ndarray, body: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(face (478, 3), left hand (21, 3), right hand (21, 3)) of one (H, W, 3) uint8 RGB frame
        with its (23, 3) body keypoints."""
        rgb = np.ascontiguousarray(rgb)
        return self.face(rgb, body), self.hand(rgb, body, "left"), self.hand(rgb, body, "right")

    def close(self) -> None:
        for g in (self._face, self._hands):
            g.close()

    def __enter__(self) -> "FaceHandsDetector":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def detect_landmarks(frames, keypoints: np.ndarray, detector: FaceHandsDetector,
                     progress: Callable[[int], None] = lambda i: None) -> FaceHandLandmarks:
    """Landmarks of every frame of ``frames`` (an iterable of (H, W, 3) uint8 RGB) with its body
    keypoints ``keypoints`` (N, 23, 3)."""
    face, left, right = [], [], []
    for i, rgb in enumerate(frames):
        f, lh, rh = detector.detect(rgb, keypoints[i])
        face.append(f)
        left.append(lh)
        right.append(rh)
        progress(i)
    return FaceHandLandmarks(np.stack(face), np.stack(left), np.stack(right), "mediapipe")


def detect_project_landmarks(project, detector: FaceHandsDetector | None = None,
                             progress: Callable[[int], None] = lambda i: None) -> FaceHandLandmarks:
    """Detect the face and hands in every frame of a capture project (placed by its body
    keypoints) and store them beside the keypoints, under the project's ``landmarks`` lock."""
    from morf.io.lock import project_lock

    own = detector is None
    detector = detector or FaceHandsDetector()
    try:
        with project_lock(project.root, "landmarks"):
            kp = project.load_keypoints().points
            frames = (project.load_frame(i) for i in range(project.num_frames))
            lm = detect_landmarks(frames, kp, detector, progress)
            save_landmarks(project.root, lm)
    finally:
        if own:
            detector.close()
    return lm
