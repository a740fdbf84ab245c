"""Choosing and following one person, checked with a stand-in detector (white blocks = people)."""

from __future__ import annotations

import cv2
import numpy as np

from morf.capture.detect_mediapipe import Detection
from morf.capture.keypoint_layout import NUM_KEYPOINTS
from morf.capture.people import (BoxFollower, PersonTracker, TrackerConfig, box_iou, expand_box, find_people,
                                 search_regions)


class BlockDetector:
    """Finds the largest pure-white block, like a one-person pose detector would find a person."""

    def __init__(self):
        self.calls = 0

    def detect(self, rgb: np.ndarray) -> Detection:
        self.calls += 1
        h, w = rgb.shape[:2]
        white = (rgb.min(axis=2) >= 250).astype(np.uint8)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(white)
        if n <= 1:
            return Detection.empty(h, w)
        k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        x, y, bw, bh = stats[k, :4]
        pts = np.zeros((NUM_KEYPOINTS, 3), np.float32)
        gx, gy = np.meshgrid(np.linspace(0.1, 0.9, 5), np.linspace(0.25, 0.95, 5))  # keypoints below the head top
        pts[:, 0] = x + bw * gx.ravel()[:NUM_KEYPOINTS]
        pts[:, 1] = y + bh * gy.ravel()[:NUM_KEYPOINTS]
        pts[:, 2] = 1.0
        return Detection(pts, (labels == k).astype(np.float32), True)


def scene(blocks, w=320, h=180) -> np.ndarray:
    img = np.full((h, w, 3), 60, np.uint8)
    for x0, y0, x1, y1 in blocks:
        img[y0:y1, x0:x1] = 255
    return img


def test_box_helpers():
    a = np.array([0, 0, 10, 10.0])
    assert box_iou(a, a) == 1.0
    assert box_iou(a, np.array([20, 20, 30, 30.0])) == 0.0
    assert box_iou(a, np.array([5, 0, 15, 10.0])) == np.float64(50 / 150)
    assert expand_box(a, 2.0, 100, 100).tolist() == [0, 0, 15, 15]  # clipped at the border
    assert len(search_regions(100, 100)) == 1
    wide = search_regions(1768, 994)
    assert len(wide) == 4 and all(r[3] - r[1] == 994 for r in wide[1:])
    assert wide[-1][2] == 1768


def test_find_people_finds_every_block_largest_first():
    det = BlockDetector()
    people = find_people(det, scene([(20, 40, 60, 160), (200, 20, 280, 170), (120, 100, 140, 140)]))
    boxes = [b for _, b in people]
    assert len(boxes) == 3
    areas = [(b[2] - b[0]) * (b[3] - b[1]) for b in boxes]
    assert areas == sorted(areas, reverse=True)
    assert boxes[0][0] < 200 < boxes[0][2]  # the big block first


def test_follower_keeps_its_person_even_when_another_grows_larger():
    f = BoxFollower(min_iou=0.25, reacquire_after=3)
    big, small = np.array([0, 0, 10, 20.0]), np.array([50, 0, 55, 10.0])
    seq = [[big, small], [small, big], [np.array([50, 0, 70, 40.0]), big + 1]]
    chosen = []
    for boxes in seq:
        f.next_frame()
        chosen.append(f.choose(boxes))
    assert chosen == [0, 1, 1]
    for _ in range(2):  # the person leaves: no choice, no switch to the other one
        f.next_frame()
        assert f.choose([np.array([50, 0, 70, 40.0])]) is None
    assert f.rechosen == []
    f.next_frame()
    assert f.choose([np.array([50, 0, 70, 40.0])]) is None
    f.next_frame()  # after reacquire_after misses the largest is chosen afresh, and that is recorded
    assert f.choose([np.array([50, 0, 70, 40.0])]) == 0
    assert f.rechosen == [6]


def test_tracker_follows_the_largest_through_a_crossing():
    det = BlockDetector()
    tracker = PersonTracker(det, TrackerConfig(probe_frames=1, recheck_every=4))
    xs = []
    for t in range(8):
        a = (100 + 2 * t, 30, 140 + 2 * t, 170)  # the followed person, large, drifting right
        b = (260 - 12 * t, 90, 280 - 12 * t, 130)  # a smaller person walking left past them
        d = tracker.update(scene([a, b]))
        assert d.found
        xs.append(float(np.mean(d.points[:, 0])))
        cols = np.nonzero(d.mask.any(axis=0))[0]
        assert cols.min() >= a[0] - 8 and cols.max() <= a[2] + 8  # no bystander pixels in the mask
    assert all(100 <= x <= 160 for x in xs), xs
    assert tracker.people_seen == 2
