"""2D keypoints and a person mask from MediaPipe's legacy pose solution (BlazePose, offline).

Only ``model_complexity=1`` works without a network: its models ship inside the
``mediapipe==0.10.14`` wheel, the other complexities try to download theirs. The legacy
solution finds one person per image; :mod:`morf.capture.people` builds the choice of which
person on top of it (crops around the person being followed).
"""

from __future__ import annotations

import contextlib
import os
import sys
import warnings
from dataclasses import dataclass

import numpy as np

from morf.capture.keypoint_layout import MEDIAPIPE_TO_OURS, NUM_KEYPOINTS
from morf.capture.mirror_average import mirror_average
from morf.errors import MorfError

# protobuf 4 warns once per process about an API MediaPipe 0.10.14 still calls
warnings.filterwarnings("ignore", message=r"SymbolDatabase\.GetPrototype\(\) is deprecated", category=UserWarning)

MASK_THRESHOLD = 0.5  # segmentation probability above which a pixel belongs to the person


@dataclass(frozen=True)
class Detection:
    """One image's detection.

    Fields:
        points: (23, 3) float32, x and y in pixels of the input image, confidence in [0, 1]
            (MediaPipe's landmark visibility; 0 for points MediaPipe does not have).
        mask: (H, W) float32 person segmentation probability in [0, 1] (zeros when not found).
        found: whether a person was detected at all.
    """

    points: np.ndarray
    mask: np.ndarray
    found: bool

    @staticmethod
    def empty(height: int, width: int) -> "Detection":
        return Detection(np.zeros((NUM_KEYPOINTS, 3), np.float32), np.zeros((height, width), np.float32), False)

    def binary_mask(self, threshold: float = MASK_THRESHOLD) -> np.ndarray:
        """(H, W) bool person mask."""
        return self.mask > threshold


def landmarks_to_ours(landmarks: np.ndarray, width: int, height: int) -> np.ndarray:
    """(33, 3) MediaPipe landmarks (x, y normalised to [0, 1], visibility) -> (23, 3) in pixels."""
    out = np.zeros((NUM_KEYPOINTS, 3), np.float32)
    for src, dst in MEDIAPIPE_TO_OURS.items():
        x, y, vis = landmarks[src]
        out[dst] = (x * width, y * height, np.clip(vis, 0.0, 1.0))
    return out


@contextlib.contextmanager
def _quiet_native_logs():
    """Silence what MediaPipe's C++ side prints to stderr while it starts (TFLite delegate
    notices, absl warnings): it says nothing a user can act on and buries the progress bar."""
    if os.environ.get("MORF_DEBUG"):
        yield
        return
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


class MediaPipeDetector:
    """Wraps ``mediapipe.solutions.pose.Pose`` with segmentation.

    ``static_image_mode=True`` (the default) treats every call independently; that is what
    crops around a followed person need, since consecutive inputs are different windows (and what
    ``mirror_average`` needs: its second pass sees the mirror image).
    Not thread-safe: use one detector per thread. Call :meth:`close` (or use ``with``).
    """

    def __init__(self, static_image_mode: bool = True, min_detection_confidence: float = 0.5,
                 mirror_average: bool = False):
        try:
            with _quiet_native_logs():
                from mediapipe.python.solutions import pose as mp_pose
        except ImportError as e:  # a broken or missing install is the user's environment
            raise MorfError(f"MediaPipe is not installed ({e}): pip install --no-deps mediapipe==0.10.14 (morf brings what "
                           "it needs; without --no-deps pip adds jax and the non-headless OpenCV)") from None
        with _quiet_native_logs():
            self._pose = mp_pose.Pose(static_image_mode=static_image_mode, model_complexity=1,
                                      enable_segmentation=True, smooth_segmentation=False,
                                      min_detection_confidence=min_detection_confidence)
            # The graph opens its models on worker threads, which print start-up notices a
            # moment later; one call on a blank image waits for them inside the quiet window.
            self._pose.process(np.zeros((64, 64, 3), np.uint8))
        self.mirror_average = mirror_average

    def detect(self, rgb: np.ndarray) -> Detection:
        """(H, W, 3) uint8 RGB -> :class:`Detection` in that image's pixel coordinates. With
        ``mirror_average`` the keypoints are also detected on the mirrored image and averaged with
        it where the two agree (:mod:`morf.capture.mirror_average`); the mask is the plain pass's."""
        rgb = np.ascontiguousarray(rgb)
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise ValueError(f"detect wants (H, W, 3) uint8 RGB, got {rgb.shape} {rgb.dtype}")
        found = self._detect(rgb)
        if not (self.mirror_average and found.found):
            return found
        mirrored = self._detect(np.ascontiguousarray(rgb[:, ::-1]))
        if not mirrored.found:
            return found
        return Detection(mirror_average(found.points, mirrored.points, rgb.shape[1]), found.mask, True)

    def _detect(self, rgb: np.ndarray) -> Detection:
        h, w = rgb.shape[:2]
        result = self._pose.process(rgb)
        if result.pose_landmarks is None:
            return Detection.empty(h, w)
        lm = np.array([(p.x, p.y, p.visibility) for p in result.pose_landmarks.landmark], np.float32)
        if result.segmentation_mask is not None:
            mask = np.asarray(result.segmentation_mask, np.float32)
        else:
            mask = np.zeros((h, w), np.float32)
        return Detection(landmarks_to_ours(lm, w, h), mask, True)

    def close(self) -> None:
        if self._pose is not None:
            self._pose.close()
            self._pose = None

    def __enter__(self) -> "MediaPipeDetector":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
