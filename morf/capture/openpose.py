"""OpenPose JSON import: body keypoints (BODY_25 or COCO-18), hands and face.

One JSON file per frame, as OpenPose's ``--write_json`` writes them::

    {"people": [{"pose_keypoints_2d": [x, y, c, ...],        # 75 (BODY_25) or 54 (COCO-18)
                 "hand_left_keypoints_2d": [...],             # 63 = 21 x 3, optional
                 "hand_right_keypoints_2d": [...],            # 63, optional
                 "face_keypoints_2d": [...]}]}                # 210 = 70 x 3, optional

OpenPose puts pixel centres on integers; MoRF puts them at +0.5 (see morf/camera.py), so
x and y are shifted by half a pixel on import. Undetected points are (0, 0, 0) in OpenPose
and keep confidence 0 here.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.capture.keypoint_layout import BODY25_TO_OURS, OPENPOSE_COCO18_TO_OURS, remap
from morf.errors import InputError
from morf.io.arrays import first_outside

NUM_HAND = 21
NUM_FACE = 70
_BODY_LAYOUTS = {75: ("BODY_25", BODY25_TO_OURS), 54: ("COCO-18", OPENPOSE_COCO18_TO_OURS)}
_EXTRA = {"hand_left_keypoints_2d": NUM_HAND, "hand_right_keypoints_2d": NUM_HAND, "face_keypoints_2d": NUM_FACE}
# How far outside the frame a point may lie, in frame sizes: OpenPose guesses a little beyond
# the edges; farther means keypoints of another video, another scale, or a broken writer.
MAX_FRAMES_OUTSIDE = 2.0
CONFIDENCE_SLACK = 1e-3  # writers that round 1.0 up a hair


@dataclass(frozen=True)
class OpenPosePerson:
    """One person from one OpenPose file, in MoRF pixel coordinates.

    Fields:
        body: (23, 3) float32 x, y, confidence in our keypoint layout.
        hand_left, hand_right: (21, 3) float32 or None when the file has no hand points.
        face: (70, 3) float32 or None.
        layout: "BODY_25" or "COCO-18".
        pose: (25 or 18, 3) float32 the file's own body points (MoRF pixels), some of which
            ``body`` leaves out; checked against the frame size with the rest.
    """

    body: np.ndarray
    hand_left: np.ndarray | None
    hand_right: np.ndarray | None
    face: np.ndarray | None
    layout: str
    pose: np.ndarray | None = None

    def all_points(self) -> np.ndarray:
        """(K, 3) every point this person has (body, hands, face), for boxing the person."""
        parts = [p for p in (self.body, self.hand_left, self.hand_right, self.face) if p is not None]
        return np.concatenate(parts, 0)


def _numbers(values, count: int, key: str, path: Path) -> np.ndarray:
    if not isinstance(values, list) or len(values) != count * 3:
        n = len(values) if isinstance(values, list) else type(values).__name__
        raise InputError(f"malformed OpenPose file {path}: {key} has {n} values, expected {count * 3}")
    try:
        a = np.asarray(values, dtype=np.float64).reshape(count, 3)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"malformed OpenPose file {path}: {key} holds values that are not numbers") from None
    big = float(np.finfo(np.float32).max)  # stored as float32: nothing may overflow to inf there
    bad = first_outside(a, [-big, -big, 0.0], [big, big, 1.0 + CONFIDENCE_SLACK])
    if bad is not None:
        (k, c), v = bad
        raise InputError(f"malformed OpenPose file {path}: {key} point {k} has {('x', 'y', 'confidence')[c]} {v:g}; "
                         + ("a confidence lies in [0, 1]" if c == 2 and np.isfinite(v) else
                            "coordinates are finite pixel positions and confidences lie in [0, 1]"))
    a[:, 2] = np.minimum(a[:, 2], 1.0)
    return a.astype(np.float32)


def _to_morf_pixels(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    seen = a[:, 2] > 0
    a[seen, :2] += 0.5
    return a


def read_openpose_json(path: str | Path) -> list[OpenPosePerson]:
    """Every person in one OpenPose JSON file (people with no body points are skipped)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"malformed OpenPose file {path}: {e}") from None
    except OSError as e:
        raise InputError(f"cannot read OpenPose file {path}: {e.strerror}") from None
    if not isinstance(data, dict) or not isinstance(data.get("people"), list):
        raise InputError(f"malformed OpenPose file {path}: no 'people' list")
    people = []
    for k, person in enumerate(data["people"]):
        if not isinstance(person, dict):
            raise InputError(f"malformed OpenPose file {path}: people[{k}] is not an object")
        raw = person.get("pose_keypoints_2d", [])
        if isinstance(raw, list) and len(raw) == 0:
            continue
        n = len(raw) if isinstance(raw, list) else -1
        if n not in _BODY_LAYOUTS:
            raise InputError(f"malformed OpenPose file {path}: pose_keypoints_2d has {n if n >= 0 else 'no list of'} "
                             f"values, expected 75 (BODY_25) or 54 (COCO-18)")
        layout, mapping = _BODY_LAYOUTS[n]
        src = _to_morf_pixels(_numbers(raw, n // 3, "pose_keypoints_2d", path))
        body = remap(src[None], mapping)[0]
        extra = {}
        for key, count in _EXTRA.items():
            vals = person.get(key)
            extra[key] = None if not vals else _to_morf_pixels(_numbers(vals, count, key, path))
        people.append(OpenPosePerson(body, extra["hand_left_keypoints_2d"], extra["hand_right_keypoints_2d"],
                                     extra["face_keypoints_2d"], layout, src))
    return people


def check_pixel_coordinates(people: list[OpenPosePerson], width: int, height: int, path: Path) -> None:
    """Points in pixels of the ``width`` x ``height`` frames their file belongs to: OpenPose can
    write coordinates scaled to [0, 1] or [-1, 1] (MoRF needs pixels), and points more than
    :data:`MAX_FRAMES_OUTSIDE` frame sizes outside the frame are no keypoints of this video."""
    pts = np.concatenate([p.body for p in people], 0) if people else np.zeros((0, 3))
    seen = pts[pts[:, 2] > 0, :2]
    if len(seen) >= 3 and np.abs(seen).max() <= 1.5 and max(width, height) > 64:
        raise InputError(f"OpenPose file {path} holds normalised coordinates; "
                         f"write pixel coordinates (OpenPose --keypoint_scale 0)")
    size = np.array([width, height], np.float64)
    low, high = -MAX_FRAMES_OUTSIDE * size, (1 + MAX_FRAMES_OUTSIDE) * size
    for person in people:
        parts = {"pose_keypoints_2d": person.pose if person.pose is not None else person.body,
                 "hand_left_keypoints_2d": person.hand_left, "hand_right_keypoints_2d": person.hand_right,
                 "face_keypoints_2d": person.face}
        for key, points in parts.items():
            bad = None if points is None else first_outside(points[:, :2], low, high)
            if bad is not None:
                (i, c), v = bad
                v -= 0.5 if points[i, 2] > 0 else 0.0  # as the file writes it
                raise InputError(f"OpenPose file {path}: {key} point {i} has {'xy'[c]} = {v:g} px, "
                                 f"more than {MAX_FRAMES_OUTSIDE:g} frame sizes outside the {width}x{height} frames; "
                                 "are these keypoints of another video, or scaled?")


@dataclass(frozen=True)
class HandsFace:
    """Hand and face points of the followed person, every frame.

    Fields:
        hand_left, hand_right: (N, 21, 3) float32 x, y, confidence (zeros where absent).
        face: (N, 70, 3) float32.
        present: (N,) bool, whether the frame's file had hand or face points for the person.
    """

    hand_left: np.ndarray
    hand_right: np.ndarray
    face: np.ndarray
    present: np.ndarray

    @staticmethod
    def stack(people: list[OpenPosePerson | None], scale: float) -> "HandsFace":
        """Stack per-frame persons (None = nobody), scaling x, y by ``scale`` (a resize)."""
        n = len(people)
        out = {"hand_left": np.zeros((n, NUM_HAND, 3), np.float32), "hand_right": np.zeros((n, NUM_HAND, 3), np.float32),
               "face": np.zeros((n, NUM_FACE, 3), np.float32)}
        present = np.zeros(n, bool)
        for i, p in enumerate(people):
            if p is None:
                continue
            for name in out:
                a = getattr(p, name)
                if a is not None:
                    out[name][i] = a
                    out[name][i, :, :2] *= scale
                    present[i] = True
        return HandsFace(out["hand_left"], out["hand_right"], out["face"], present)

