"""The detail scores: a sharp render two pixels off beats a blurred one, where PSNR picks the blur."""

import numpy as np
import pytest

from morf.evaluate.detail import gmsd, inside_mask, max_shift_for, region_scores
from morf.evaluate.detail_eval import summarize_detail
from morf.evaluate.regions import frame_boxes, square_box


def _textured(side: int = 96, seed: int = 0) -> np.ndarray:
    """(3, side, side) float image with edges at many scales: discs and strokes on grey."""
    import cv2

    rng = np.random.default_rng(seed)
    img = np.full((side, side, 3), 128, np.uint8)
    for _ in range(30):
        centre = tuple(int(v) for v in rng.integers(4, side - 4, 2))
        cv2.circle(img, centre, int(rng.integers(1, 6)), rng.integers(0, 256, 3).tolist(), -1)
    for _ in range(8):
        a, b = (tuple(int(v) for v in rng.integers(0, side, 2)) for _ in range(2))
        cv2.line(img, a, b, rng.integers(0, 256, 3).tolist(), 1)
    return img.transpose(2, 0, 1).astype(np.float64) / 255


def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    from scipy.ndimage import gaussian_filter

    return np.stack([gaussian_filter(c, sigma) for c in img])


@pytest.mark.parametrize("seed", [0, 1])
def test_blur_loses_to_a_sharp_render_two_pixels_off(seed):
    real = _textured(seed=seed)
    blurred = _blur(real, 1.5)
    shifted = np.roll(real, (2, -2), axis=(1, 2))
    box = (12, 12, 84, 84)
    b, s = region_scores(blurred, real, box), region_scores(shifted, real, box)
    assert b.psnr > s.psnr + 1  # PSNR prefers the blur ...
    assert s.ssim_shift > b.ssim_shift + 0.1  # ... the shift-tolerant SSIM does not,
    assert s.gmsd < b.gmsd - 0.05  # nor GMSD (lower is better),
    assert s.hf_ratio == pytest.approx(1, abs=0.05) and b.hf_ratio < 0.5  # and the blur's detail is missing
    assert s.shift == (2, -2) and b.shift == (0, 0)


def test_identical_regions_score_perfectly_and_a_shift_beyond_the_window_does_not():
    real = _textured()
    same = region_scores(real, real, (10, 10, 80, 80))
    assert same.ssim_shift == pytest.approx(1) and same.gmsd == pytest.approx(0, abs=1e-9)
    assert same.hf_ratio == pytest.approx(1) and same.shift == (0, 0) and same.pixels == 70 * 70
    far = region_scores(np.roll(real, 7, axis=2), real, (10, 10, 80, 80), max_shift=4)
    assert far.ssim_shift < 0.8  # 7 px is outside +-4: no free pass
    assert region_scores(np.roll(real, 7, axis=2), real, (10, 10, 80, 80), max_shift=8).ssim_shift > 0.99


def _matted(img: np.ndarray, mask: np.ndarray, alpha: np.ndarray | None = None) -> np.ndarray:
    """``img`` over grey through ``mask``, or through a soft ``alpha`` as a render's."""
    a = mask.astype(np.float64) if alpha is None else alpha
    return img * a + 0.5 * (1 - a)


def test_inside_ratio_sees_the_face_where_the_box_sees_the_matte_edge():
    from scipy.ndimage import gaussian_filter

    real_img = 0.8 + 0.3 * (_textured(seed=2) - 0.5)  # a light face with faint features, on grey
    yy, xx = np.mgrid[:96, :96]
    mask = (yy - 48) ** 2 + (xx - 48) ** 2 < 30 ** 2  # a head: a disc, binary as a capture's mask
    soft = np.clip(gaussian_filter(mask.astype(np.float64), 1.5), 0, 1)  # a render's alpha
    real = _matted(real_img, mask)
    box, inside = (8, 8, 88, 88), inside_mask(mask)
    same_face = region_scores(_matted(real_img, mask, soft), real, box, inside=inside)
    assert same_face.hf_ratio < 0.9  # the soft edge alone costs the box's ratio ...
    assert same_face.hf_ratio_inside == pytest.approx(1, abs=0.05)  # ... not the inside one
    blurred = region_scores(_matted(_blur(real_img, 1.5), mask, soft), real, box, inside=inside)
    assert blurred.hf_ratio_inside < 0.5  # a blurred face still loses inside
    noisy = _matted(real_img + np.random.default_rng(0).normal(0, 0.05, real_img.shape), mask, soft)
    assert region_scores(noisy, real, box, inside=inside).hf_ratio_inside > 1.2  # and noise shows as over 1
    assert region_scores(real, real, box).hf_ratio_inside == pytest.approx(1)  # no mask: the whole box
    small = (yy - 48) ** 2 + (xx - 48) ** 2 < 24 ** 2  # a render whose head is 6 px too small
    shrunk = _matted(real_img, small)
    assert region_scores(shrunk, real, box, inside=inside).hf_ratio_inside > 1.5  # its edge counts as detail ...
    both = region_scores(shrunk, real, box, inside=inside, inside_pred=inside_mask(small))
    assert both.hf_ratio_inside == pytest.approx(1, abs=0.02)  # ... unless its own edge is left out too


def test_inside_mask_keeps_the_pixels_away_from_the_edge_but_not_the_image_border():
    mask = np.zeros((20, 20), bool)
    mask[:, :10] = True  # a person cut by the image's left border
    got = inside_mask(mask, 3)
    assert got[:, :8].all() and not got[:, 8:].any()  # 3 px or more from the first pixel outside


def test_boxes_at_the_image_border_stay_defined():
    real = _textured(64)
    s = region_scores(np.roll(real, 1, axis=1), real, (0, 0, 20, 64))
    assert np.isfinite([s.psnr, s.ssim_shift, s.gmsd, s.hf_ratio]).all() and s.ssim_shift > 0.9


def test_gmsd_rises_with_blur():
    real = _textured()
    values = [gmsd(_blur(real, s), real) for s in (0.5, 1.0, 2.0)]
    assert values == sorted(values) and values[0] > 0


def test_tolerated_shift_scales_with_resolution():
    assert max_shift_for(576, 576) == 4 and max_shift_for(256, 576) == 2 and max_shift_for(64, 576) == 1
    assert max_shift_for(1152, 576) == 8


def test_boxes_come_from_the_visible_part_pixels():
    parts = np.zeros((100, 100), np.uint8)
    parts[10:30, 40:60] = 1  # head
    parts[70:80, 10:20] = 2  # left hand
    parts[70:72, 80:82] = 3  # a right hand too small to score
    person = parts > 0
    boxes = frame_boxes(parts, person)
    assert set(boxes) == {"person", "head", "hand.L"}
    assert boxes["head"] == (6, 36, 34, 64)  # grown by 20% of 20 px on each side
    assert boxes["hand.L"] == (67, 7, 83, 23)
    y0, x0, y1, x1 = square_box((0, 90, 10, 100), 100, 100)
    assert (y1 - y0, x1 - x0) == (10, 10) and (y0, x1) == (0, 100)


def test_summary_pools_both_hands_and_ratios_summed_energy():
    real = _textured()
    blurred = _blur(real, 1.5)
    head = region_scores(real, real, (10, 10, 50, 50))
    hand = region_scores(blurred, real, (50, 50, 90, 90))
    out = summarize_detail([{"head": head, "hand.L": hand}, {"hand.R": hand}])
    assert out["head_count"] == 1 and out["hands_count"] == 2 and out["person_count"] == 0
    assert out["person_ssim_shift"] is None and out["head_ssim_shift"] == pytest.approx(1)
    assert out["hands_hf_ratio"] == pytest.approx(hand.hf_ratio, abs=1e-5)
    assert out["hands_gmsd"] == pytest.approx(hand.gmsd, abs=1e-5)


def test_large_regions_find_the_shift_coarse_to_fine():
    from morf.evaluate.detail import COARSE_PIXELS, best_shift

    real = _textured(220, seed=3)
    assert 200 * 200 > COARSE_PIXELS
    for shift in [(3, -1), (-4, 4), (0, 2)]:
        assert best_shift(np.roll(real, shift, axis=(1, 2)), real, (10, 10, 210, 210), 4) == shift


def test_head_frames_name_each_scored_head_and_flag_the_shift_bound():
    from morf.evaluate.detail import RegionScores
    from morf.evaluate.detail_eval import head_frames

    def r(ssim, shift):
        return RegionScores(20.0, ssim, 0.1, 1.0, 1.0, shift, 100)

    per = [{"head": r(0.8, (0, 1)), "person": r(0.9, (0, 0))}, {"person": r(0.9, (0, 0))},
           {"head": r(0.5, (-4, 2))}, {"head": r(0.7, (1, 4))}]
    heads = head_frames(per, [10, 15, 20, 25], 4)
    assert [h["frame"] for h in heads] == [10, 20, 25]  # frame 15 shows no head
    assert [h["at_bound"] for h in heads] == [False, True, True]
    assert heads[1] == {"frame": 20, "ssim_shift": 0.5, "shift": [-4, 2], "at_bound": True}
