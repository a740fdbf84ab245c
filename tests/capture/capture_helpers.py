"""Tiny synthetic inputs for the capture tests: videos, image folders, OpenPose files, masks."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np


def frame_image(i: int, w: int = 64, h: int = 48) -> np.ndarray:
    """(h, w, 3) uint8 BGR with a white block whose position depends on i (a 'person')."""
    img = np.full((h, w, 3), 40, np.uint8)
    x = 8 + (i % 5) * 4
    img[8:h - 8, x:x + 16] = 255
    return img


def write_video(path: Path, n: int, w: int = 64, h: int = 48, fps: float = 10.0) -> Path:
    """An MJPG AVI of n frames (MJPG: every frame is a key frame, so cuts decode cleanly)."""
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (w, h))
    assert vw.isOpened()
    for i in range(n):
        vw.write(frame_image(i, w, h))
    vw.release()
    return path


def write_frames(folder: Path, n: int, w: int = 64, h: int = 48, pattern: str = "img_{i}.png") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        cv2.imwrite(str(folder / pattern.format(i=i)), frame_image(i, w, h))
    return folder


def write_masks(folder: Path, n: int, w: int = 64, h: int = 48, pattern: str = "mask_{i:04d}.png") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        cv2.imwrite(str(folder / pattern.format(i=i)), (frame_image(i, w, h)[..., 0] == 255).astype(np.uint8) * 255)
    return folder


def body25(x0: float, y0: float, x1: float, y1: float, conf: float = 0.9) -> list[float]:
    """75 OpenPose numbers: the BODY_25 points spread over a box (a stand-in person)."""
    pts = np.zeros((25, 3))
    rng = np.random.default_rng(int(x0 * 7 + y0))
    pts[:, 0] = rng.uniform(x0, x1, 25)
    pts[:, 1] = rng.uniform(y0, y1, 25)
    pts[:, 2] = conf
    pts[8, 2] = 0.0  # OpenPose's mid-hip has no place in our layout; 0 confidence like a miss
    return pts.ravel().tolist()


def write_openpose(folder: Path, n: int, people_boxes, hands: bool = False,
                   pattern: str = "video_{i:012d}_keypoints.json") -> Path:
    """One JSON per frame; ``people_boxes`` is a list of boxes, each giving one person per frame."""
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        people = []
        for b in people_boxes:
            p = {"person_id": [-1], "pose_keypoints_2d": body25(*b)}
            if hands:
                p["hand_left_keypoints_2d"] = [1.0, 2.0, 0.5] * 21
                p["hand_right_keypoints_2d"] = [3.0, 4.0, 0.6] * 21
                p["face_keypoints_2d"] = [5.0, 6.0, 0.7] * 70
            people.append(p)
        (folder / pattern.format(i=i)).write_text(json.dumps({"version": 1.3, "people": people}))
    return folder



def write_timed_video(path: Path, frames_bgr: list[np.ndarray], times: list[float], rotation: int = 0) -> Path:
    """An H.264 .mp4 written with PyAV: frame i shown at ``times[i]`` seconds (any spacing: a
    variable frame rate clip), and a display matrix turning it ``rotation`` degrees
    counter-clockwise (a phone's ``rotate=90`` tag is -90)."""
    from fractions import Fraction

    import av

    h, w = frames_bgr[0].shape[:2]
    tb = Fraction(1, 1000)
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=30)
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.codec_context.time_base = tb
        stream.options = {"crf": "10"}
        if rotation:
            stream.set_display_rotation(rotation)
        for bgr, t in zip(frames_bgr, times):
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(bgr[..., ::-1]), format="rgb24")
            frame.pts, frame.time_base = int(round(t / tb)), tb
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path
