"""Per-frame labels: the followed person's 2D keypoints and mask, detected or imported.

Four combinations, one rule each:

* nothing imported: MediaPipe through :class:`~morf.capture.people.PersonTracker`;
* masks imported: the imported mask says where the person is, so MediaPipe runs on a crop
  around it (the mask picks the person; no tracker needed);
* OpenPose keypoints imported: the largest person is followed by box overlap
  (:class:`~morf.capture.people.BoxFollower`), and MediaPipe segments a crop around that
  person for the mask;
* both imported: no detector runs at all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.capture.detect_mediapipe import Detection, MediaPipeDetector
from morf.capture.keypoint_layout import NUM_KEYPOINTS
from morf.capture.mask_import import read_mask, resize_mask
from morf.capture.matching import FileMatch, count_mismatch
from morf.capture.openpose import OpenPosePerson, check_pixel_coordinates, read_openpose_json
from morf.capture.people import (BoxFollower, PersonTracker, TrackerConfig, box_iou, detect_in_region,
                                 expand_box, keypoint_box, person_box)
from morf.errors import InputError


@dataclass(frozen=True)
class FrameLabel:
    """One frame's labels, in output-frame pixels.

    Fields:
        points: (23, 3) float32 x, y, confidence.
        mask: (H, W) bool person mask (None once written to disk).
        found: whether the person's keypoints were found.
        source: "mediapipe" | "openpose".
        person: the OpenPose person (hands, face; source pixels) or None.
    """

    points: np.ndarray
    mask: np.ndarray
    found: bool
    source: str
    person: OpenPosePerson | None = None


def mask_box(mask: np.ndarray) -> np.ndarray | None:
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        return None
    return np.array([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1], float)


class FrameLabeller:
    """Labels frames one after another (it keeps the person-following state)."""

    def __init__(self, keypoints: FileMatch | None, masks: FileMatch | None, source_size: tuple[int, int],
                 scale: float, tracker: TrackerConfig = TrackerConfig(), mirror_average: bool = False):
        self.keypoints, self.masks = keypoints, masks
        self.source_size, self.scale, self.config = source_size, scale, tracker
        # the mirrored pass only where MediaPipe's keypoints are used (not for a mask alone)
        self.detector = (MediaPipeDetector(mirror_average=mirror_average and keypoints is None)
                         if keypoints is None or masks is None else None)
        self.tracker = PersonTracker(self.detector, tracker) if keypoints is None and masks is None else None
        self.follower = BoxFollower(tracker.min_iou, tracker.reacquire_after)
        self._people_seen = 0
        self.layouts: set[str] = set()  # OpenPose body layouts met
        self.has_hands_face = False
        self.warnings: list[str] = []

    @property
    def mirror_average(self) -> bool:
        """Whether the keypoints are MediaPipe's averaged with its pass on the mirrored frame."""
        return self.detector is not None and self.detector.mirror_average

    @property
    def people_seen(self) -> int:
        return max(self._people_seen, self.tracker.people_seen if self.tracker else 0)

    @property
    def rechosen_frames(self) -> list[int]:
        """Output frame indices where the largest person was chosen afresh after losing the first."""
        return (self.tracker.follower if self.tracker else self.follower).rechosen

    def label(self, index: int, rgb: np.ndarray) -> FrameLabel:
        """Labels of source frame ``index``, whose (possibly resized) pixels are ``rgb``."""
        h, w = rgb.shape[:2]
        mask = None
        if self.masks is not None:
            mask = resize_mask(read_mask(self.masks.get(index), *self.source_size), w, h)
        if self.keypoints is not None:
            return self._label_openpose(index, rgb, mask)
        if mask is None:
            det = self.tracker.update(rgb)
            return FrameLabel(det.points, det.binary_mask(), det.found, "mediapipe")
        box = mask_box(mask)
        det = Detection.empty(h, w)
        if box is not None:
            det = detect_in_region(self.detector, rgb, expand_box(box, 1.3, w, h, square=True), self.config.max_side)
            self._people_seen = max(self._people_seen, 1)
        return FrameLabel(det.points, mask, det.found, "mediapipe")

    def _label_openpose(self, index: int, rgb: np.ndarray, mask: np.ndarray | None) -> FrameLabel:
        h, w = rgb.shape[:2]
        path = self.keypoints.get(index)
        people = read_openpose_json(path)
        check_pixel_coordinates(people, *self.source_size, path)
        self._people_seen = max(self._people_seen, len(people))
        self.follower.next_frame()
        boxes = [keypoint_box(p.all_points()) for p in people]
        usable = [k for k, b in enumerate(boxes) if b is not None]
        k = self.follower.choose([boxes[j] for j in usable])
        person = people[usable[k]] if k is not None else None
        if person is None:
            return FrameLabel(np.zeros((NUM_KEYPOINTS, 3), np.float32),
                              mask if mask is not None else np.zeros((h, w), bool), False, "openpose")
        self.layouts.add(person.layout)
        self.has_hands_face |= any(a is not None for a in (person.hand_left, person.hand_right, person.face))
        points = person.body.copy()
        points[:, :2] *= self.scale
        if mask is None:
            box = boxes[usable[k]] * self.scale
            det = detect_in_region(self.detector, rgb, expand_box(box, 1.4, w, h, square=True), self.config.max_side)
            found_box = person_box(det)
            if found_box is None or box_iou(found_box, box) < 0.2:
                mask = np.zeros((h, w), bool)  # MediaPipe saw somebody else (or nobody) there
            else:
                x0, y0, x1, y1 = expand_box(box, 1.15, w, h).round().astype(int)
                mask = np.zeros((h, w), bool)
                mask[y0:y1, x0:x1] = det.binary_mask()[y0:y1, x0:x1]
        return FrameLabel(points, mask, True, "openpose", person)

    def check_complete(self, frames_used: int, source_total: int | None, ended_early: bool) -> None:
        """After the last frame: side files matched by order must number exactly the frames."""
        if source_total is None or ended_early:
            return
        for match in (self.keypoints, self.masks):
            if match is not None and match.rule == "order" and match.total != source_total:
                raise count_mismatch(match.total, match.what, source_total)

    def close(self) -> None:
        if self.detector is not None:
            self.detector.close()

