"""Back-projection of the frames into the colour texture, and the choice of its passes on the capture."""

import dataclasses

import cv2
import numpy as np
import pytest

from morf.errors import InputError
from morf.train.back_project import back_project, choose_back_projections
from morf.train.config import TrainConfig
from morf.train.floor_texture import floor_texture
from morf.train.frames import FrameSet
from morf.train.inpaint import project_rgb_texture
from morf.train.texel_splat import Projection

SIZE, H = 64, 32  # frames 32 px wide over half the atlas: a texel a pixel, the head's density


def _truth(seed: int = 0) -> np.ndarray:
    """(SIZE, SIZE, 3) float32 colours with detail at 1-3 texels."""
    rng = np.random.default_rng(seed)
    img = np.full((SIZE, SIZE, 3), 0.5, np.float32)
    for _ in range(60):
        c = tuple(int(v) for v in rng.integers(0, SIZE, 2))
        cv2.circle(img, c, int(rng.integers(1, 3)), rng.uniform(0, 1, 3).tolist(), -1)
    return img


def _frames(n: int = 8, jitter: float = 0.0, seed: int = 0) -> FrameSet:
    """``n`` frames of the truth through the bilinear lookup, each a fraction of a pixel further on;
    ``jitter`` > 0 texels: each frame's colours moved by a random offset of up to that much (frames
    that disagree, as a fit a few pixels off makes them)."""
    from morf.train.colour_align import sample_colour
    from morf.train.frames import UV_SCALE

    rng = np.random.default_rng(seed)
    truth = _truth()
    y, x = np.mgrid[0:H, 0:H].astype(np.float32) + 0.5
    images, uvs = [], []
    for i in range(n):
        uv = np.stack([0.25 + x / H * 0.5 + i / (3.7 * SIZE), 0.75 - y / H * 0.5 + i / (5.3 * SIZE)], -1)
        off = rng.uniform(-jitter, jitter, 2) / SIZE if jitter else np.zeros(2)
        seen_at = np.clip((uv + off) * UV_SCALE, 0, UV_SCALE).astype(np.uint16)
        images.append(np.clip(sample_colour(truth, seen_at, np.ones((H, H), bool)) * 255 + 0.5, 0, 255).astype(np.uint8))
        uvs.append(uv)
    ones = np.ones((n, H, H), bool)
    fs = FrameSet.from_float(np.stack(images), ones, np.stack(uvs).astype(np.float32), ones, np.zeros((n, 2, 3)))
    return dataclasses.replace(fs, facing=np.full((n, H, H), 255, np.uint8))


def _drawn_back_error(rgb: np.ndarray, fs: FrameSet) -> float:
    from morf.train.colour_align import sample_colour

    return float(np.mean([np.abs(sample_colour(rgb, fs.uv[i], fs.uv_mask[i]) - fs.images[i] / 255.0).mean()
                          for i in range(fs.num_frames)]))


def _hf(img: np.ndarray) -> float:
    from scipy.ndimage import gaussian_filter

    lum = img.mean(-1)
    return float(((lum - gaussian_filter(lum, 1.0)) ** 2).sum())


def test_passes_give_back_the_detail_the_splat_and_the_lookup_blur():
    fs = _frames()
    how = Projection(bilinear=True)
    plain, seen = project_rgb_texture(fs, SIZE, how=how)
    sharp = back_project(plain, seen, fs, 0.3, how, 3)
    assert (sharp[~seen] == 0).all() and 0 <= sharp.min() and sharp.max() <= 1
    assert _drawn_back_error(sharp, fs) < 0.6 * _drawn_back_error(plain, fs)  # the frames drawn back match better
    inside = (slice(20, 44), slice(20, 44))
    truth = _truth()[inside]
    assert _hf(sharp[inside]) > 1.5 * _hf(plain[inside])  # the detail comes back ...
    assert np.abs(sharp[inside] - truth).mean() < np.abs(plain[inside] - truth).mean()  # ... where it was
    again = back_project(back_project(plain, seen, fs, 0.3, how, 1), seen, fs, 0.3, how, 2)
    np.testing.assert_allclose(again, sharp, atol=1e-5)  # passes compose: 1 then 2 is 3
    covered = np.ones((SIZE, SIZE), bool)
    floor = floor_texture(fs, covered, how=dataclasses.replace(how, back_projections=3))[0][:3].transpose(1, 2, 0)
    np.testing.assert_allclose(floor[seen], sharp[seen], atol=1e-6)  # the floor texture applies the passes


def test_the_choice_takes_passes_where_frames_agree_and_none_where_they_do_not():
    how = Projection(bilinear=True)
    agree = choose_back_projections(_frames(12), SIZE, 0.3, how)
    assert agree.passes == 1 and agree.frames == 6 and agree.scores[1] > agree.scores[0]  # at most one by default
    more = choose_back_projections(_frames(12), SIZE, 0.3, how, most=3)
    assert more.passes >= 1 and more.scores[:2] == agree.scores[:2]
    disagree = choose_back_projections(_frames(12, jitter=4.0), SIZE, 0.3, how)
    assert disagree.passes == 0 and disagree.scores[1] < disagree.scores[0]
    assert len(disagree.scores) == 2  # stopped at the first pass that did not pay
    assert choose_back_projections(_frames(3), SIZE, 0.3, how).passes == 0  # too few frames to hold any aside
    assert "back-projection" in agree.describe()


def test_config_takes_minus_one_for_the_choice_and_refuses_less():
    TrainConfig(colour_back_projections=-1).validate()
    with pytest.raises(InputError, match="colour_back_projections"):
        TrainConfig(colour_back_projections=-2).validate()
