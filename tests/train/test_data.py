import numpy as np
import pytest
import torch

from morf.camera import PinholeCamera
from morf.train.data import crop_camera, crop_image, crop_of, person_square


def test_crop_camera_matches_crop_image():
    cam = PinholeCamera.look_at(200, 100, 40, eye=(0, -4, 0.5), target=(0, 0, 0.5))
    p = torch.tensor([[0.1, 0.0, 0.9]])
    x, y = cam.project(p)[0].tolist()
    img = np.zeros((100, 200), np.uint8)
    img[int(y) - 1:int(y) + 2, int(x) - 1:int(x) + 2] = 255
    x0, y0, side = 60.0, -20.0, 120.0  # partly above the image: zero padding
    work = crop_camera(cam, x0, y0, side, 60)
    crop = crop_image(img, x0, y0, side, 60)
    xw, yw = work.project(p)[0].tolist()
    ys, xs = np.nonzero(crop > 40)
    assert abs(xs.mean() + 0.5 - xw) < 1.0 and abs(ys.mean() + 0.5 - yw) < 1.0
    assert np.allclose(crop_of(cam, work), (x0, y0, side))


def test_person_square_has_margin_and_is_square():
    m = np.zeros((50, 80), bool)
    m[10:40, 30:40] = True
    x0, y0, side = person_square([m], margin=0.1)
    assert side == pytest.approx(30 * 1.2)
    assert x0 < 30 and x0 + side > 40 and y0 < 10 and y0 + side > 40
