"""Close-ups drawn at the trained scale: the wider camera and the box that maps back onto the asked view."""

import numpy as np
import torch

from morf.raster.camera_paths import front_camera
from morf.raster.view_scale import MARGIN, close_up, enlarge, pixels_per_metre


def test_pixels_per_metre_is_focal_over_depth():
    cam = front_camera(640, distance=2.0)
    near, far = pixels_per_metre(cam, (0, 0, 0)), pixels_per_metre(front_camera(640, distance=4.0), (0, 0, 0))
    assert 1.9 < near / far < 2.1  # twice as close, twice as large
    assert pixels_per_metre(cam, (0, -10.0, 0)) == 0.0  # behind the camera


def test_a_close_camera_is_drawn_wider_and_its_box_maps_back():
    cam = front_camera(640, distance=1.0)
    limit = pixels_per_metre(cam, (0, 0, 0)) / 3.0  # the body shown at 3x the trained scale
    assert close_up(cam, (0, 0, 0), limit * 3.0 / MARGIN) is None  # within the margin: drawn as asked
    assert close_up(cam, (0, 0, 0), None) is None  # no recorded scale: no limit
    near = close_up(cam, (0, 0, 0), limit)
    assert near is not None and abs(near.factor - 3.0 / MARGIN) < 1e-9
    assert abs(pixels_per_metre(near.camera, (0, 0, 0)) - limit * MARGIN) < 1e-6
    pts = torch.tensor([[0.1, 0.0, 0.3], [-0.2, 0.05, -0.4], [0.0, 0.0, 0.0]])
    asked, wide = cam.project(pts).numpy(), near.camera.project(pts).numpy()
    x0, y0, x1, y1 = near.box
    back = np.stack([(wide[:, 0] - x0) * 640 / (x1 - x0), (wide[:, 1] - y0) * 640 / (y1 - y0)], 1)
    np.testing.assert_allclose(back, asked, atol=1e-3)  # every point lands where the asked camera puts it


def test_enlarge_resamples_the_box_to_the_full_size():
    img = np.zeros((64, 64, 3), np.uint8)
    img[16:48, 16:48] = 200  # a square in the middle half
    out = enlarge(img, (16.0, 16.0, 48.0, 48.0))
    assert out.shape == img.shape and out[2:-2, 2:-2].min() == 200  # the middle half now fills the image
    same = enlarge(img, (0.0, 0.0, 64.0, 64.0))
    np.testing.assert_array_equal(same, img)
