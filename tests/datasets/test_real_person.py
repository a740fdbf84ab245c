"""A real person photo (../shared/data) in ZJU-MoCap's layout: MediaPipe finds the person in the mask."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from morf.capture.project import CaptureProject
from morf.datasets import ZjuMocapConfig, import_zju_mocap
from tests.datasets.fakes import zju_camera
from tests.conftest import require


def test_keypoints_land_on_the_masked_person(shared_data, tmp_path):
    require("mediapipe")
    rgba = cv2.imread(str(shared_data / "images" / "ryota.png"), cv2.IMREAD_UNCHANGED)
    mask = cv2.imread(str(shared_data / "images" / "ryota_mask.png"), cv2.IMREAD_GRAYSCALE) > 127
    bgr = rgba[..., :3]
    folder = tmp_path / "CoreView_377"
    ims = []
    for i in range(2):
        shifted = np.roll(bgr, 8 * i, axis=1)  # the person steps sideways between frames
        (folder / "Camera_B1").mkdir(parents=True, exist_ok=True)
        (folder / "mask_cihp" / "Camera_B1").mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(folder / "Camera_B1" / f"{i:06d}.jpg"), shifted)
        cv2.imwrite(str(folder / "mask_cihp" / "Camera_B1" / f"{i:06d}.png"), np.roll(mask, 8 * i, axis=1).astype(np.uint8))
        ims.append({"ims": [f"Camera_B1/{i:06d}.jpg"]})
    K, R, T = zju_camera(0)
    K = np.array([[600.0, 0, 256], [0, 600.0, 256], [0, 0, 1]])
    np.save(folder / "annots.npy", np.array({"cams": {"K": [K], "R": [R], "T": [T], "D": [np.zeros((5, 1))]},
                                             "ims": ims}, dtype=object), allow_pickle=True)
    res = import_zju_mocap(folder, tmp_path / "proj", ZjuMocapConfig(view_every=0))
    assert res.detected == 2
    project = CaptureProject.open(tmp_path / "proj")
    kp = project.load_keypoints()
    for n in range(2):
        m = project.load_mask(n)
        pts = kp.points[n][kp.points[n, :, 2] > 0.5]
        assert len(pts) >= 10
        xy = np.clip(pts[:, :2].round().astype(int), 0, 511)
        near = cv2.dilate(m.astype(np.uint8), np.ones((15, 15), np.uint8)).astype(bool)  # joints sit near the outline
        inside = near[xy[:, 1], xy[:, 0]]
        assert inside.mean() > 0.9
