import numpy as np
import torch

from morf.avatar.texture import NeuralTexture, sample_texture, texel_centre_uvs, uv_to_grid
from morf.avatar.uv_atlas import dilate_texture, rasterize_uv_atlas


def test_texel_centres_return_texels_exactly():
    tex = torch.arange(2 * 4 * 5, dtype=torch.float32).reshape(2, 4, 5)
    uv = texel_centre_uvs(4, 5)[None]
    out = sample_texture(tex, uv)
    assert out.shape == (1, 2, 4, 5)
    assert torch.equal(out[0], tex)


def test_v_up_convention_row0_is_top():
    tex = torch.zeros(1, 8, 8)
    tex[0, 0, :] = 1.0  # top row of the texture = v near 1
    top = sample_texture(tex, torch.tensor([[[[0.5, 1 - 0.5 / 8]]]]))
    bottom = sample_texture(tex, torch.tensor([[[[0.5, 0.5 / 8]]]]))
    assert float(top) == 1.0 and float(bottom) == 0.0
    assert torch.allclose(uv_to_grid(torch.tensor([0.0, 1.0])), torch.tensor([-1.0, -1.0]))


def test_bilinear_between_texels_and_mask():
    tex = torch.tensor([[[0.0, 1.0]]])  # (1, 1, 2)
    uv = torch.tensor([[[[0.5, 0.5], [0.25, 0.5]]]])
    out = sample_texture(tex, uv, torch.tensor([[[True, False]]]))
    assert torch.allclose(out[0, 0, 0], torch.tensor([0.5, 0.0]))


def test_neural_texture_module_batches():
    nt = NeuralTexture(3, 4, 4)
    assert nt(torch.rand(2, 5, 6, 2)).shape == (2, 3, 5, 6)


def test_uv_atlas_interpolates_vertex_values_and_dilates():
    uvs = np.array([[0, 0], [1, 0], [0, 1]], float)  # lower-left half of the atlas
    atlas = rasterize_uv_atlas(uvs, np.array([[0, 1, 2]]), 16, 16)
    cov = atlas.covered
    assert cov[-1, 0] and not cov[0, -1]  # bottom-left texel (v ~ 0) inside, top-right outside
    vals = atlas.interpolate(uvs)  # interpolating the UVs themselves gives the texel-centre UVs
    centres = texel_centre_uvs(16, 16).numpy()
    assert np.allclose(vals[cov], centres[cov], atol=1e-5)
    grown, gcov = dilate_texture(vals, cov, 2)
    assert gcov.sum() > cov.sum() and np.array_equal(grown[cov], vals[cov])


def test_sampling_with_offsets_equals_sampling_the_warped_texture():
    from morf.avatar.warp import warp_texture

    g = torch.Generator().manual_seed(0)
    tex = torch.rand(4, 8, 8, generator=g)
    off = torch.zeros(1, 2, 8, 8)
    off[:, 0], off[:, 1] = 0.3 * 2 / 8, -1.0 * 2 / 8  # a third of a texel right, one texel up
    uv = texel_centre_uvs(8, 8)[None]
    direct = sample_texture(tex, uv, None, off)
    via_warp = sample_texture(warp_texture(tex, off)[0], uv)
    assert torch.allclose(direct, via_warp, atol=1e-6)
    assert not torch.allclose(direct, sample_texture(tex, uv), atol=1e-3)
