"""The RGB floor on hand-made frames: the texture it projects, the side it picks, how it renders."""

import numpy as np
import pytest
import torch

from morf.avatar.passthrough import PassthroughRenderer
from morf.avatar.texture import texel_centre_uvs
from morf.train.floor import floor_config, floor_request
from morf.train.floor_texture import choose_floor_size, floor_texture
from morf.train.frames import FrameSet
from morf.train.trained_avatar import load_trained_avatar, save_trained_avatar

S = 16  # texture side of the hand-made case


def _texel_centre(row: int, col: int) -> tuple[float, float]:
    return (col + 0.5) / S, 1 - (row + 0.5) / S


def _one_frame():
    """One 16x16 frame: pixel (y, x) with x < 8 looks at texel (y, x); pixel (0, 9) also looks at
    texel (3, 3), so that texel is seen twice and texel (3, 2) once; the rest sees nothing."""
    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, size=(1, S, S, 3), dtype=np.uint8)
    uv = np.zeros((1, S, S, 2), np.float32)
    cover = np.zeros((1, S, S), bool)
    for y in range(S):
        for x in range(8):
            uv[0, y, x] = _texel_centre(y, x)
            cover[0, y, x] = True
    uv[0, 0, 9] = _texel_centre(3, 3)
    cover[0, 0, 9] = True
    fs = FrameSet.from_float(img, cover, uv, cover, np.zeros((1, 4, 3), np.float32))
    return fs, img[0]


def test_floor_renders_the_projected_colour_exactly_at_a_texel_seen_once(tmp_path):
    fs, img = _one_frame()
    texture, seen = floor_texture(fs, np.ones((S, S), bool), dilate=2)
    assert texture.shape == (4, S, S) and np.all(texture[3] == 1)
    assert seen[3, 2] and seen[3, 3]
    cfg = floor_config(floor_request(S, 0), S)
    save_trained_avatar(tmp_path / "avatar.pt", torch.from_numpy(texture), PassthroughRenderer(), cfg.to_dict(),
                        None, None)
    av = load_trained_avatar(tmp_path / "avatar.pt")
    assert av.method == "rgb" and isinstance(av.renderer, PassthroughRenderer)
    uv = texel_centre_uvs(S, S)[None]
    mask = torch.ones(1, S, S, dtype=torch.bool)
    mask[0, 0, 0] = False  # a pixel off the mesh
    rgb, alpha = av.render(uv, mask)
    once = torch.from_numpy((img[3, 2].astype(np.float64) / 255).astype(np.float32))
    assert torch.equal(rgb[0, :, 3, 2], once)  # exactly the pixel's colour
    twice = (img[3, 3].astype(np.float64) + img[0, 9]) / 510
    assert np.allclose(rgb[0, :, 3, 3].numpy(), twice, atol=1e-6)  # the mean of its two pixels
    assert alpha[0, 0, 3, 2] == 1 and alpha[0, 0, 0, 0] < 1e-8 and torch.all(rgb[0, :, 0, 0] == 0)
    assert float(rgb[0, :, 8:, 12:].mean()) > 0.05  # texels no pixel saw are filled from their neighbours


@pytest.mark.parametrize("res", [64, 128, 256])
def test_texture_side_follows_the_sampling_of_the_frames(res):
    # one frame whose pixel centres tile the whole atlas: one pixel per texel at side ``res``
    yy, xx = np.mgrid[0:res, 0:res].astype(np.float32) + 0.5
    uv = np.stack([xx / res, 1 - yy / res], -1)[None]
    cover = np.ones((1, res, res), bool)
    fs = FrameSet.from_float(np.zeros((1, res, res, 3), np.uint8), cover, uv, cover, np.zeros((1, 4, 3), np.float32))
    choice = choose_floor_size(fs)
    assert choice.size == res
    assert choice.hit_share[res] == 1.0
    if res < 1024:
        assert choice.hit_share[2 * res] == 0.25  # one child of each hit texel: a pixel per texel
    assert "texture" in choice.describe()
