"""What a fit reads from a capture project: keypoints, detection flags, masks, camera."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from morf.camera import PinholeCamera
from morf.errors import InputError


@dataclass(frozen=True)
class FitInputs:
    """Fields:
        keypoints: (N, 23, 3) float32 x, y (pixels) and confidence; zero confidence where missing.
        detected: (N,) bool, a person was detected.
        camera: the static camera (full-resolution pixels).
        masks: (N, h, w) float32 person coverage in [0, 1] at the silhouette resolution, or None.
        mask_scale: h / image height (the silhouette raster's scale).
        masks_eval: (N, he, we) bool person masks at the evaluation resolution, or None.
        eval_scale: he / image height.
        frame_times: (N,) seconds of each frame (the capture's times, or index / fps), or None.
        unordered: the frames are views in no particular order (a photo set), not a clip.
        landmarks: (N, 49, 3) float32 face anchors, ears and both hands' 21 points (x, y pixels,
            confidence; :func:`morf.fitting.head_hands.landmark_targets`), or None without any.
        keypoint_source: (N,) str where each frame's keypoints come from ("mediapipe", "openpose",
            "ground_truth", "none"; detectors mark ears differently), or None when unknown.
    """

    keypoints: np.ndarray
    detected: np.ndarray
    camera: PinholeCamera
    masks: np.ndarray | None = None
    mask_scale: float = 1.0
    masks_eval: np.ndarray | None = None
    eval_scale: float = 1.0
    frame_times: np.ndarray | None = None
    unordered: bool = False
    landmarks: np.ndarray | None = None
    keypoint_source: np.ndarray | None = None

    @property
    def num_frames(self) -> int:
        return int(self.keypoints.shape[0])

    @property
    def image_size(self) -> tuple[int, int]:
        return self.camera.width, self.camera.height


def raster_size(width: int, height: int, long_side: int) -> tuple[int, int, float]:
    """(w, h, scale) of a raster whose long side is ``long_side`` pixels."""
    s = long_side / max(width, height)
    return max(1, int(round(width * s))), max(1, int(round(height * s))), s


def downsample_mask(mask: np.ndarray, w: int, h: int) -> np.ndarray:
    """(H, W) bool -> (h, w) float32 area coverage in [0, 1]."""
    return cv2.resize(mask.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)


def load_fit_inputs(project, camera: PinholeCamera, silhouette_resolution: int, eval_resolution: int,
                    need_masks: bool = True) -> FitInputs:
    """Read keypoints and (if present) masks of every frame of a :class:`CaptureProject`."""
    if project.num_frames == 0:
        raise InputError(f"{project.root} has no frames")
    if not (project.root / "keypoints.npz").is_file():
        raise InputError(f"{project.root} has no keypoints.npz; run 'morf ingest' first")
    kp = project.load_keypoints()
    W, H = project.image_size
    if (camera.width, camera.height) != (W, H):
        raise InputError(f"camera is {camera.width}x{camera.height} but frames are {W}x{H}")
    points = np.nan_to_num(kp.points.astype(np.float32), nan=0.0)
    points[~kp.detected, :, 2] = 0.0
    have_masks = need_masks and all(project.mask_path(i).is_file() for i in range(project.num_frames))
    masks = masks_eval = None
    sw, sh, ss = raster_size(W, H, silhouette_resolution)
    ew, eh, es = raster_size(W, H, eval_resolution)
    if have_masks:
        masks = np.zeros((project.num_frames, sh, sw), np.float32)
        masks_eval = np.zeros((project.num_frames, eh, ew), bool)
        for i in range(project.num_frames):
            m = project.load_mask(i)
            if m.shape != (H, W):
                raise InputError(f"mask {i} is {m.shape[1]}x{m.shape[0]}, frames are {W}x{H}")
            masks[i] = downsample_mask(m, sw, sh)
            masks_eval[i] = downsample_mask(m, ew, eh) >= 0.5
    unordered = project.unordered_views
    return FitInputs(points, kp.detected.astype(bool), camera, masks, sh / H, masks_eval, eh / H,
                     None if unordered else project.frame_times(), unordered, project_landmarks(project, points),
                     np.asarray(kp.source).astype(str))


def project_landmarks(project, points: np.ndarray) -> np.ndarray | None:
    """(N, 49, 3) the project's face and hand evidence as the head-and-hands refinement takes it:
    its detected landmarks, else the OpenPose face and hand points ingest imported; None without."""
    from morf.capture.landmarks_face_hands import load_landmarks
    from morf.fitting.head_hands import landmark_targets

    lm = load_landmarks(project)
    if lm is None:
        return None
    return landmark_targets(lm.face_anchors(), lm.hand_left, lm.hand_right, points)
