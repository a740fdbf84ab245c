"""The colour projection's bilinear splatting and its neighbourhood prior (morf.train.texel_splat)."""

import dataclasses

import cv2
import numpy as np

from morf.train.frames import UV_SCALE, FrameSet
from morf.train.inpaint import project_rgb_texture
from morf.train.texel_splat import Projection, shrunk_means, texel_weights


def _packed(u, v):
    return np.array([[u, v]], np.float64) * UV_SCALE


def test_bilinear_weights_share_a_pixel_and_land_on_a_texel_centre():
    size = 8
    # u = (2 + 0.5) / 8 is texel column 2's centre; v = 1 - (5 + 0.5) / 8 its row 5
    on_centre = texel_weights(_packed(2.5 / size, 1 - 5.5 / size), size, bilinear=True)
    weights = {int(lin[0]): float(w[0]) for lin, w in on_centre}
    assert abs(weights[5 * size + 2] - 1) < 1e-6 and abs(sum(weights.values()) - 1) < 1e-9
    between = texel_weights(_packed(3.0 / size, 1 - 5.5 / size), size, bilinear=True)  # half way to column 3
    shares = {int(lin[0]): float(w[0]) for lin, w in between if w[0] > 0}
    assert set(shares) == {5 * size + 2, 5 * size + 3} and all(abs(s - 0.5) < 1e-6 for s in shares.values())
    (lin, w), = texel_weights(_packed(3.0 / size, 1 - 5.5 / size), size, bilinear=False)
    assert w is None and int(lin[0]) == 5 * size + 3  # the plain projection: the texel the UV falls in


def test_prior_draws_a_lone_texel_to_its_neighbours_and_keeps_a_well_seen_one():
    S = 16
    acc = np.zeros((S, S, 3))
    cnt = np.zeros((S, S))
    acc[:, :] = 0.5 * 20
    cnt[:, :] = 20  # grey, twenty pixels each
    acc[8, 8], cnt[8, 8] = 1.0, 1  # one white pixel alone (a speckle)
    acc[3, 3], cnt[3, 3] = 1.0 * 200, 200  # white seen by many pixels: real detail
    out = shrunk_means(acc, cnt, prior_count=4)
    assert abs(out[8, 8, 0] - 0.5) < 0.15  # mostly its neighbourhood's grey (plain mean: 1.0)
    assert out[3, 3, 0] > 0.97  # keeps its own white
    assert abs(out[12, 12, 0] - 0.5) < 1e-6  # a uniform patch is unchanged
    zero = shrunk_means(acc, cnt, prior_count=0)
    np.testing.assert_allclose(zero, acc / cnt[..., None])  # k = 0: the plain mean


def _dense_atlas_frames() -> FrameSet:
    """Frames 16 px wide looking at half of a 64-texel atlas: two texels a pixel, the head's
    situation at 256 px (u runs across the image, v down it)."""
    n, H = 3, 16
    y, x = np.mgrid[0:H, 0:H].astype(np.float32) + 0.5
    images = np.zeros((n, H, H, 3), np.uint8)
    uvs = np.zeros((n, H, H, 2), np.float32)
    for i in range(n):
        shift = i / (3 * H)  # each frame sees the atlas a third of a pixel further on
        uvs[i, ..., 0] = 0.25 + (x / H) * 0.5 + shift
        uvs[i, ..., 1] = 0.75 - (y / H) * 0.5
        images[i] = (200 * ((x // 4 + y // 4) % 2))[..., None].astype(np.uint8) + 20
    fs = FrameSet.from_float(images, np.ones((n, H, H), bool), uvs, np.ones((n, H, H), bool), np.zeros((n, 2, 3)))
    return dataclasses.replace(fs, facing=np.full((n, H, H), 255, np.uint8))


def test_bilinear_splat_closes_the_pinholes_of_a_dense_atlas():
    fs = _dense_atlas_frames()
    _, seen_nearest = project_rgb_texture(fs, 64)
    rgb, seen_bilinear = project_rgb_texture(fs, 64, how=Projection(bilinear=True))
    inside = np.zeros((64, 64), bool)
    inside[18:46, 20:46] = True  # well inside the region every frame covers
    assert seen_nearest[inside].mean() <= 0.5  # every other row of texels is never hit
    assert seen_bilinear[inside].all()
    assert (seen_bilinear | ~seen_nearest).all()  # every texel hit before is still seen
    assert 0 <= rgb.min() and rgb.max() <= 1


def test_projection_defaults_are_the_plain_mean(frames_factory):
    fs = frames_factory(n=3, res=32)
    plain, seen = project_rgb_texture(fs, 32)
    same, seen2 = project_rgb_texture(fs, 32, how=Projection(bilinear=False, prior_count=0.0))
    assert np.array_equal(plain, same) and np.array_equal(seen, seen2)
    shrunk, seen3 = project_rgb_texture(fs, 32, how=Projection(prior_count=4.0))
    assert np.array_equal(seen, seen3) and not np.array_equal(plain, shrunk)
    assert np.abs(shrunk[seen] - plain[seen]).mean() < 0.1  # drawn, not replaced


def test_a_negative_prior_count_is_refused():
    import pytest

    from morf.errors import InputError
    from morf.train.config import preset

    with pytest.raises(InputError, match="colour_prior_count"):
        preset("tiny", colour_prior_count=-1)


def test_edge_inset_keeps_the_backdrop_at_the_outline_out_of_the_colour():
    """A person mask one pixel too wide takes the backdrop's green into the texels seen at the
    outline; an inset of one pixel leaves those pixels out: every texel left is the person's colour."""
    n, H = 2, 32
    y, x = np.mgrid[0:H, 0:H]
    uvs = np.zeros((n, H, H, 2), np.float32)
    uvs[..., 0], uvs[..., 1] = 0.25 + (x / H) * 0.5, 0.75 - (y / H) * 0.5
    person = (np.abs(x - 15.5) < 8) & (np.abs(y - 15.5) < 8)
    images = np.zeros((n, H, H, 3), np.uint8)
    images[:] = (30, 200, 40)  # the green backdrop
    images[:, person] = (180, 120, 90)  # the person, inside the mesh's coverage
    mask = cv2.dilate(person.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)  # the mask: 1 px too wide
    cover = np.broadcast_to(mask, (n, H, H))
    fs = FrameSet.from_float(images, cover, uvs, cover, np.zeros((n, 2, 3)))
    fs = dataclasses.replace(fs, facing=np.full((n, H, H), 255, np.uint8))
    rgb, seen = project_rgb_texture(fs, 32)
    inset, seen_inset = project_rgb_texture(fs, 32, how=Projection(edge_inset=1))
    green = (rgb[..., 1] > 0.6) & seen
    assert green.sum() > 20  # the outline's pixels coloured the texels they fell on
    assert seen_inset.sum() < seen.sum() and (seen_inset <= seen).all()
    assert np.allclose(inset[seen_inset], np.array([180, 120, 90]) / 255)  # the person's colour alone


def test_a_negative_edge_inset_is_refused():
    import pytest

    from morf.errors import InputError
    from morf.train.config import preset

    with pytest.raises(InputError, match="colour_edge_inset"):
        preset("tiny", colour_edge_inset=-1)


def test_outline_weight_leaves_the_masks_rim_out():
    import torch

    from morf.train.objective import outline_weight

    mask = torch.zeros(1, 1, 12, 12)
    mask[..., 3:9, 3:9] = 1
    assert outline_weight(mask, 0) is None
    w = outline_weight(mask, 1)
    assert w.shape == mask.shape and float(w[..., 3:9, 3:9].sum()) == 16  # the 6 x 6 square keeps its inner 4 x 4
    assert bool((w[..., 0, :] == 1).all())  # the backdrop keeps its weight
