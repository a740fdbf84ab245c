import torch

from morf.avatar.model import AvatarModel, bake_texture
from morf.avatar.renderer import RendererConfig
from morf.avatar.warp import WarpConfig, WarpField, fourier_encoding, offsets_to_rgb, warp_texture

CFG = WarpConfig(pose_dim=9, latent_dim=4, style_dim=8, mlp_layers=2, fourier_freqs=2, base_resolution=8, width=4, levels=2)


def test_zero_offsets_are_identity():
    tex = torch.rand(3, 16, 12)
    assert torch.allclose(warp_texture(tex, torch.zeros(2, 2, 16, 12))[1], tex, atol=1e-6)


def test_one_texel_offset_shifts_texture():
    tex = torch.rand(1, 8, 8)
    off = torch.zeros(1, 2, 8, 8)
    off[:, 0] = 2 / 8  # one texel to the right
    out = warp_texture(tex, off)[0]
    assert torch.allclose(out[:, :, :-1], tex[:, :, 1:], atol=1e-6)


def test_fresh_warp_is_identity_and_shapes():
    torch.manual_seed(0)
    w = WarpField(CFG, num_frames=5)
    off = w(torch.randn(3, 9), torch.tensor([0, 1, 4]), (16, 16))
    assert off.shape == (3, 2, 16, 16) and torch.count_nonzero(off) == 0
    assert fourier_encoding(8, 8, 2).shape == (10, 8, 8)


def test_bake_equals_warped_sampling_at_neutral_pose_and_mean_latent():
    torch.manual_seed(0)
    model = AvatarModel(torch.rand(3, 16, 16), RendererConfig(in_channels=3, width=4, depth=1, stem=2, skip_hidden=4),
                        CFG, num_frames=4)
    torch.nn.init.normal_(model.warp.out.weight, std=0.05)  # a non-trivial warp
    torch.nn.init.normal_(model.warp.latents.weight)
    model.warp.set_pose_statistics(torch.randn(10, 9))
    baked = model.bake()
    pose = torch.zeros(1, 9)
    off = model.warp.offsets(pose, model.warp.latents.weight.mean(0, keepdim=True), (16, 16))
    assert off.abs().max() > 1e-3
    assert torch.allclose(baked, warp_texture(model.texture.texture, off)[0])
    assert not torch.allclose(baked, model.texture.texture)
    assert torch.equal(bake_texture(model.texture.texture, None), model.texture.texture)


def test_offsets_colour_coding():
    img = offsets_to_rgb(torch.randn(2, 5, 7))
    assert img.shape == (5, 7, 3) and img.dtype == torch.uint8
