"""Which person to follow when a frame shows several.

MediaPipe's legacy pose solution returns one person per image, and which one it returns can
change from frame to frame. MoRF makes the choice explicit:

* **Finding people** (:func:`find_people`): run the detector on the (downscaled) frame and on
  square tiles of it, paint each found person's box over with the frame's mean colour and run
  it again, until nobody more is found. No extra model is needed, and every person found comes
  with keypoints and a mask. (OpenCV's HOG people detector was tried first on the real
  two-person sample: it missed both people and fired on the same empty spot in every frame.)
* **Choosing**: in the first frame where anybody is found, the largest person (box area) is
  chosen; the first ``probe_frames`` frames are searched whole, so their people are counted.
* **Following** (:class:`PersonTracker`): each later frame is cropped around the followed
  person's last box (enlarged), the detector runs on the crop, and the result is mapped back.
  A detection whose box barely overlaps the last box is treated as somebody else: the frame is
  searched whole and the person overlapping the last box most is taken; if nobody overlaps,
  the frame is marked "no person detected". Every ``recheck_every`` frames the whole frame is
  searched anyway, which counts the people in view. After ``reacquire_after`` frames in a row
  without the person, the largest person is chosen afresh (recorded, so it is never silent).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from morf.capture.detect_mediapipe import Detection

CONF_MIN = 0.3  # keypoint confidence that counts a point as seen when boxing a person


# ---- boxes (x0, y0, x1, y1) in pixels, float --------------------------------------------
def box_area(b: np.ndarray) -> float:
    return float(max(b[2] - b[0], 0.0) * max(b[3] - b[1], 0.0))


def box_iou(a: np.ndarray, b: np.ndarray) -> float:
    ix = max(min(a[2], b[2]) - max(a[0], b[0]), 0.0)
    iy = max(min(a[3], b[3]) - max(a[1], b[1]), 0.0)
    inter = ix * iy
    union = box_area(a) + box_area(b) - inter
    return float(inter / union) if union > 0 else 0.0


def expand_box(b: np.ndarray, factor: float, width: int, height: int, square: bool = False) -> np.ndarray:
    """Scale a box about its centre by ``factor`` (optionally to a square), clipped to the image."""
    cx, cy = (b[0] + b[2]) / 2, (b[1] + b[3]) / 2
    hw, hh = (b[2] - b[0]) * factor / 2, (b[3] - b[1]) * factor / 2
    if square:
        hw = hh = max(hw, hh)
    return np.array([max(cx - hw, 0), max(cy - hh, 0), min(cx + hw, width), min(cy + hh, height)], np.float64)


def keypoint_box(points: np.ndarray, conf_min: float = CONF_MIN) -> np.ndarray | None:
    """(23, 3) keypoints -> the person's box, padded (the head top lies above the eyes), or None."""
    seen = points[points[:, 2] > conf_min, :2]
    if len(seen) < 3:
        return None
    x0, y0 = seen.min(0)
    x1, y1 = seen.max(0)
    size = max(x1 - x0, y1 - y0, 1.0)
    return np.array([x0 - 0.1 * size, y0 - 0.2 * size, x1 + 0.1 * size, y1 + 0.08 * size], np.float64)


def person_box(det: Detection) -> np.ndarray | None:
    """A detection's box: its keypoints' box joined with its mask's extent near those keypoints."""
    if not det.found:
        return None
    kb = keypoint_box(det.points)
    if kb is None:
        return None
    h, w = det.mask.shape
    kb = np.array([max(kb[0], 0), max(kb[1], 0), min(kb[2], w), min(kb[3], h)])
    near = expand_box(kb, 1.3, w, h).round().astype(int)
    m = det.mask[near[1]:near[3], near[0]:near[2]] > 0.5
    if m.any():
        ys, xs = np.nonzero(m)
        mb = np.array([xs.min() + near[0], ys.min() + near[1], xs.max() + 1 + near[0], ys.max() + 1 + near[1]], float)
        kb = np.array([min(kb[0], mb[0]), min(kb[1], mb[1]), max(kb[2], mb[2]), max(kb[3], mb[3])])
    return kb if box_area(kb) > 0 else None


# ---- running the detector on part of a frame --------------------------------------------
def detect_in_region(detector, rgb: np.ndarray, region: np.ndarray | None, max_side: int) -> Detection:
    """Detect inside ``region`` (a box; None = whole frame), downscaled to ``max_side``, mapped back
    to full-frame pixels. The mask is zero outside the region."""
    h, w = rgb.shape[:2]
    if region is None:
        region = np.array([0, 0, w, h], float)
    x0, y0, x1, y1 = (int(round(v)) for v in region)
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    if x1 - x0 < 8 or y1 - y0 < 8:
        return Detection.empty(h, w)
    crop = rgb[y0:y1, x0:x1]
    s = min(1.0, max_side / max(crop.shape[:2]))
    if s < 1.0:
        crop = cv2.resize(crop, (max(1, round(crop.shape[1] * s)), max(1, round(crop.shape[0] * s))),
                          interpolation=cv2.INTER_AREA)
    det = detector.detect(np.ascontiguousarray(crop))
    if not det.found:
        return Detection.empty(h, w)
    pts = det.points.copy()
    pts[:, 0] = pts[:, 0] * (x1 - x0) / crop.shape[1] + x0
    pts[:, 1] = pts[:, 1] * (y1 - y0) / crop.shape[0] + y0
    mask = np.zeros((h, w), np.float32)
    mask[y0:y1, x0:x1] = cv2.resize(det.mask, (x1 - x0, y1 - y0), interpolation=cv2.INTER_LINEAR)
    return Detection(pts, mask, True)


def search_regions(width: int, height: int) -> list[np.ndarray]:
    """The whole frame, plus square tiles (side = the short side, half overlapping) along the long
    side of a wide or tall frame: the detector sees a whole frame at about 224 pixels, where a
    person a third of the frame's height is too small to be found."""
    regions = [np.array([0, 0, width, height], float)]
    s, long_side = min(width, height), max(width, height)
    if long_side > 1.2 * s:
        n = int(np.ceil((long_side - s) / (s / 2))) + 1
        for start in np.linspace(0, long_side - s, n):
            regions.append(np.array([start, 0, start + s, s] if width > height else [0, start, s, start + s], float))
    return regions


def same_person(a: np.ndarray, b: np.ndarray) -> bool:
    """Boxes of one person seen from two regions (one may be cut by a region's border)."""
    ix = max(min(a[2], b[2]) - max(a[0], b[0]), 0.0)
    iy = max(min(a[3], b[3]) - max(a[1], b[1]), 0.0)
    smaller = min(box_area(a), box_area(b))
    return smaller > 0 and ix * iy / smaller > 0.6


def find_people(detector, rgb: np.ndarray, max_people: int = 4, max_side: int = 960) -> list[tuple[Detection, np.ndarray]]:
    """Every person the detector finds in a frame, as (detection, box), largest first.

    Each search region is searched repeatedly, painting each person found over with the frame's
    mean colour, until nobody new turns up; the same person found from two regions is kept once
    (the larger box, which is the less cut-off view).
    """
    h, w = rgb.shape[:2]
    fill = rgb.reshape(-1, 3).mean(0).astype(np.uint8)
    people: list[tuple[Detection, np.ndarray]] = []
    for region in search_regions(w, h):
        work = rgb.copy()
        for _ in range(max_people):
            det = detect_in_region(detector, work, region, max_side)
            box = person_box(det)
            if box is None:
                break
            dup = [k for k, (_, b) in enumerate(people) if same_person(box, b)]
            if dup and box_area(people[dup[0]][1]) >= box_area(box):
                pass  # already known from another region with a fuller view
            elif dup:
                people[dup[0]] = (det, box)
            else:
                people.append((det, box))
            x0, y0, x1, y1 = expand_box(box, 1.1, w, h).round().astype(int)
            work[y0:y1, x0:x1] = fill
    people.sort(key=lambda p: -box_area(p[1]))
    return people[:max_people]


class BoxFollower:
    """The choice of person, on boxes alone (also used for imported OpenPose people).

    The largest box of the first frame with anybody is chosen; after that, the box overlapping
    the last chosen one most (IoU >= ``min_iou``). After ``reacquire_after`` frames in a row
    without the person, the largest is chosen afresh and the frame is recorded in ``rechosen``.
    """

    def __init__(self, min_iou: float = 0.25, reacquire_after: int = 10):
        self.min_iou = min_iou
        self.reacquire_after = reacquire_after
        self.last_box: np.ndarray | None = None
        self.missed = 0
        self.frame = -1
        self.rechosen: list[int] = []  # frames (in call order) where the choice was made afresh

    def next_frame(self) -> None:
        self.frame += 1

    def overlaps(self, box: np.ndarray | None) -> bool:
        return box is not None and self.last_box is not None and box_iou(box, self.last_box) >= self.min_iou

    def accept(self, box: np.ndarray) -> None:
        self.last_box, self.missed = box, 0

    def choose(self, boxes: list[np.ndarray]) -> int | None:
        """Index of the followed person among this frame's ``boxes``, or None (not in view)."""
        if self.last_box is None or self.missed >= self.reacquire_after:
            if not boxes:
                self.missed += 1
                return None
            if self.last_box is not None:
                self.rechosen.append(self.frame)
            k = max(range(len(boxes)), key=lambda j: box_area(boxes[j]))
        else:
            k = max(range(len(boxes)), key=lambda j: box_iou(boxes[j], self.last_box), default=None)
            if k is None or not self.overlaps(boxes[k]):
                self.missed += 1
                return None
        self.accept(boxes[k])
        return k


@dataclass(frozen=True)
class TrackerConfig:
    """How the followed person is chosen and kept."""

    probe_frames: int = 3  # the first this-many frames are searched whole
    recheck_every: int = 15  # search the whole frame every this-many frames (counts people)
    crop_factor: float = 1.6  # the crop around the last box, relative to the box size
    min_iou: float = 0.25  # below this overlap with the last box a detection is somebody else
    reacquire_after: int = 10  # frames without the person before the largest is chosen afresh
    max_people: int = 4  # people looked for in one frame
    max_side: int = 960  # the detector sees at most this many pixels along a side


class PersonTracker:
    """Follows one person through a sequence of frames with a MediaPipe-style detector."""

    def __init__(self, detector, config: TrackerConfig = TrackerConfig()):
        self.detector = detector
        self.config = config
        self.follower = BoxFollower(config.min_iou, config.reacquire_after)
        self.people_seen = 0  # most people seen at once in a searched frame

    @property
    def last_box(self) -> np.ndarray | None:
        return self.follower.last_box

    def search(self, rgb: np.ndarray) -> list[tuple[Detection, np.ndarray]]:
        people = find_people(self.detector, rgb, self.config.max_people, self.config.max_side)
        self.people_seen = max(self.people_seen, len(people))
        return people

    def update(self, rgb: np.ndarray) -> Detection:
        """Detect the followed person in the next frame ((H, W, 3) uint8)."""
        h, w = rgb.shape[:2]
        cfg, fol = self.config, self.follower
        fol.next_frame()
        step = fol.frame
        searched = step < cfg.probe_frames or step % cfg.recheck_every == 0
        if fol.last_box is not None and fol.missed < cfg.reacquire_after and not searched:
            # the usual case: look in a crop around where the person just was
            region = expand_box(fol.last_box, cfg.crop_factor, w, h, square=True)
            det = detect_in_region(self.detector, rgb, region, cfg.max_side)
            box = person_box(det)
            if fol.overlaps(box):
                fol.accept(box)
                return _clip_mask(det, box)
        people = self.search(rgb)
        k = fol.choose([b for _, b in people])
        if k is None:
            return Detection.empty(h, w)
        return _clip_mask(*people[k])


def _clip_mask(det: Detection, box: np.ndarray) -> Detection:
    """Keep mask pixels near the person's box only, so a bystander's pixels do not leak in."""
    h, w = det.mask.shape
    x0, y0, x1, y1 = expand_box(box, 1.15, w, h).round().astype(int)
    mask = np.zeros_like(det.mask)
    mask[y0:y1, x0:x1] = det.mask[y0:y1, x0:x1]
    return Detection(det.points, mask, det.found)
