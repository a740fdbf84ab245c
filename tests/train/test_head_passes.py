"""The head's colours' back-projection passes, chosen on heads held aside
(morf.train.head_colours.choose_head_passes), and the drawn-back score over a part of the atlas."""

import numpy as np
import pytest

from morf.rotations import rotvec_to_matrix_rodrigues
from morf.train.back_project import drawn_back_ssim
from morf.train.config import TrainConfig
from morf.train.head_colours import choose_head_passes
from morf.train.texel_splat import Projection
from tests.train.test_back_project import SIZE, _frames


def _turning(n: int) -> np.ndarray:
    """(n, 3, 3) a head turning 3 degrees a frame: a frame's nearest heads are the frames beside it."""
    return rotvec_to_matrix_rodrigues(np.stack([np.zeros(n), np.radians(3.0) * np.arange(n), np.zeros(n)], 1))


def test_passes_where_the_heads_agree_and_none_where_they_do_not():
    how = Projection(bilinear=True)
    share = np.ones((SIZE, SIZE), np.float32)
    agree = choose_head_passes(_frames(12), _turning(12), SIZE, 4, how, share)
    assert agree.passes >= 1 and agree.frames == 12 and agree.scores[1] > agree.scores[0]
    assert "back-projection pass(es)" in agree.describe()
    disagree = choose_head_passes(_frames(12, jitter=4.0), _turning(12), SIZE, 4, how, share)
    assert disagree.passes == 0 and disagree.scores[1] < disagree.scores[0]
    assert choose_head_passes(_frames(12), _turning(12), SIZE, 4, how, share, most=0).passes == 0
    assert choose_head_passes(_frames(4), _turning(4), SIZE, 4, how, share).passes == 0  # none to hold aside
    # no head in the frames (every share under a half): nothing scored, no pass
    none = choose_head_passes(_frames(12), _turning(12), SIZE, 4, how, np.full((SIZE, SIZE), 0.4, np.float32))
    assert none.passes == 0 and none.frames == 0


def test_the_drawn_back_score_counts_only_the_region():
    from morf.train.inpaint import project_rgb_texture

    how = Projection(bilinear=True)
    fs = _frames(6)
    rgb, _ = project_rgb_texture(fs, SIZE, how=how)
    spoiled = rgb.copy()
    spoiled[:, SIZE // 2:] = 0.0  # the right half of the atlas wrong
    left = np.zeros((SIZE, SIZE), bool)
    left[:, :SIZE // 2] = True
    whole = drawn_back_ssim(spoiled, fs, 0.3, how)
    assert whole < drawn_back_ssim(rgb, fs, 0.3, how) - 0.1
    assert drawn_back_ssim(spoiled, fs, 0.3, how, left) > whole + 0.1  # the left half alone is still right


def test_config_takes_the_choice_and_refuses_less():
    TrainConfig(head_view_colour_passes=-1).validate()
    with pytest.raises(Exception, match="head_view_colour_passes"):
        TrainConfig(head_view_colour_passes=-2).validate()
    with pytest.raises(Exception, match="needs view_colours"):
        TrainConfig(head_view_colours=4, view_colours=0).validate()
