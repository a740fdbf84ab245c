import numpy as np
import pytest
import torch
import torch.nn.functional as F

from morf.avatar.model import AvatarModel
from morf.avatar.renderer import RendererConfig, UNetRenderer, count_parameters
from tests.conftest import require


@pytest.mark.parametrize("stem,head_stride", [(1, 1), (2, 1), (4, 1), (2, 2), (4, 2)])
def test_output_shape_and_ranges(stem, head_stride):
    r = UNetRenderer(RendererConfig(in_channels=6, width=4, depth=2, stem=stem, skip_hidden=4, head_stride=head_stride))
    out = r(torch.randn(2, 6, 32, 48))
    assert out.shape == (2, 4, 32, 48)
    assert torch.isfinite(out).all()
    assert torch.allclose(torch.sigmoid(out[:, 3]).mean(), torch.sigmoid(torch.tensor(-2.0)), atol=0.1)


def test_presets_sizes():
    from morf.train.config import PRESETS

    cpu = count_parameters(UNetRenderer(PRESETS["cpu"].renderer))
    gpu = count_parameters(UNetRenderer(PRESETS["gpu"].renderer))
    assert 0.4e6 <= cpu <= 0.6e6  # stem x4 base 16, half-resolution head: 0.49 M (docs/avatar.md)
    assert 12e6 <= gpu <= 17e6


def test_no_pixel_unshuffle():
    r = UNetRenderer(RendererConfig(stem=4))
    assert not any(isinstance(m, (torch.nn.PixelUnshuffle, torch.nn.PixelShuffle)) for m in r.modules())


def test_avatar_model_forward():
    m = AvatarModel(torch.rand(4, 16, 16), RendererConfig(in_channels=4, width=4, depth=1, stem=2, skip_hidden=4), None, 3)
    out = m(torch.rand(2, 8, 8, 2), torch.ones(2, 8, 8, dtype=torch.bool))
    assert out.rgb.shape == (2, 3, 8, 8) and out.mask_logit.shape == (2, 1, 8, 8) and out.offsets is None


def test_onnx_export_matches_torch(tmp_path):
    ort = require("onnxruntime")
    require("onnx")
    torch.manual_seed(0)
    r = UNetRenderer(RendererConfig(in_channels=8, width=8, depth=2, stem=2, skip_hidden=8)).eval()
    x = torch.randn(1, 8, 64, 64)
    path = tmp_path / "r.onnx"
    torch.onnx.export(r, (x,), str(path), opset_version=17, input_names=["features"], output_names=["out"],
                      dynamo=False)
    import onnx

    ops = {n.op_type for n in onnx.load(str(path)).graph.node}
    assert "SpaceToDepth" not in ops and "DepthToSpace" not in ops
    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    got = sess.run(None, {"features": x.numpy()})[0]
    with torch.no_grad():
        ref = r(x).numpy()
    np.testing.assert_allclose(got, ref, atol=1e-4, rtol=1e-4)


def test_premultiplied_output_is_black_where_the_mask_is_off():
    torch.manual_seed(0)
    cfg = RendererConfig(in_channels=4, width=4, depth=1, stem=2, skip_hidden=4)
    r = UNetRenderer(cfg)
    plain = UNetRenderer(RendererConfig(**{**cfg.__dict__, "premultiply": False}))
    plain.load_state_dict(r.state_dict())
    x = torch.randn(1, 4, 16, 16)
    out, raw = r(x), plain(x)
    assert torch.allclose(out[:, 3:], raw[:, 3:])
    assert torch.allclose(out[:, :3], raw[:, :3] * torch.sigmoid(raw[:, 3:]), atol=1e-6)
    with torch.no_grad():
        r.head[-1].bias[3] = -30.0  # mask off everywhere
    assert r(x)[:, :3].abs().max() < 1e-9


def test_bf16_channels_last_forward_close_to_float32():
    from morf.avatar.texture import texel_centre_uvs

    torch.manual_seed(0)
    m = AvatarModel(torch.rand(4, 16, 16), RendererConfig(in_channels=4, width=4, depth=1, stem=2, skip_hidden=4), None, 3)
    uv, cover = texel_centre_uvs(16, 16)[None], torch.ones(1, 16, 16, dtype=torch.bool)
    ref = m(uv, cover)
    m.renderer.to(memory_format=torch.channels_last)
    fast = m(uv, cover, bf16=True)
    assert fast.rgb.dtype == torch.float32 and fast.rgb.is_contiguous()
    assert torch.allclose(fast.rgb, ref.rgb, atol=0.03) and not torch.equal(fast.rgb, ref.rgb)


def test_head_runs_its_concat_conv_split_by_resolution():
    """The full-resolution head computes conv1x1(cat(upsample(h), x)) as upsample(conv(h)) +
    conv(x): the same function as the concatenating form (state dicts are interchangeable)."""
    import torch.nn.functional as F

    torch.manual_seed(0)
    r = UNetRenderer(RendererConfig(in_channels=6, width=8, depth=2, stem=2, skip_hidden=5)).eval()
    x = torch.randn(2, 6, 32, 32)
    with torch.no_grad():
        h = F.interpolate(r.head_low(r.trunk(x)), scale_factor=2.0, mode="bilinear", align_corners=False)
        ref = r.head[:-1](torch.cat([h, x], 1))
        torch.testing.assert_close(r.features(x), ref, atol=1e-5, rtol=1e-5)


def test_half_resolution_head_reads_the_raster_through_a_strided_conv():
    """head_stride 2: the head's 1x1 convs run at half the input's size and only its 4 outputs
    are upsampled; the raster's detail still reaches every output pixel (through head_x), and
    the texture colour of rgb_skip stays at full resolution."""
    torch.manual_seed(0)
    cfg = RendererConfig(in_channels=6, width=8, depth=2, stem=4, skip_hidden=5, head_stride=2, rgb_skip=True,
                         premultiply=False)
    r = UNetRenderer(cfg).eval()
    assert r.head_x.stride == (2, 2) and r.head[0].in_channels == 8
    x = torch.rand(1, 6, 32, 32) * 0.8 + 0.1
    with torch.no_grad():
        assert r.features(x).shape[-2:] == (16, 16)
        out = r(x)
        torch.testing.assert_close(out[:, :3], x[:, :3])  # step 0: the texture colour, pixel for pixel
        r.last.weight.normal_(0, 0.1)
        y = x.clone()
        y[..., 9, 9] += 0.5  # one raster pixel changes the residual most right around it
        diff = (r(y) - r(x))[0, :3].abs().sum(0)
    at = divmod(int(diff.argmax()), 32)
    assert abs(at[0] - 9) <= 2 and abs(at[1] - 9) <= 2
    with pytest.raises(ValueError, match="head_stride"):
        UNetRenderer(RendererConfig(stem=1, head_stride=2))


def test_push_pull_fill_keeps_covered_and_fills_near_pixels():
    from morf.avatar.renderer import push_pull_fill

    rgb = torch.zeros(1, 3, 32, 32)
    cov = torch.zeros(1, 1, 32, 32)
    rgb[:, :, 8:24, 8:16] = torch.tensor([0.9, 0.2, 0.1]).view(1, 3, 1, 1)  # red block
    rgb[:, :, 8:24, 16:24] = torch.tensor([0.1, 0.2, 0.8]).view(1, 3, 1, 1)  # blue block
    cov[:, :, 8:24, 8:24] = 1
    out = push_pull_fill(rgb, cov, 4)
    assert torch.equal(out * cov, rgb * cov)  # covered pixels unchanged
    left, right = out[0, :, 16, 5], out[0, :, 16, 26]  # off the mesh, beside each block
    assert left[0] > 0.6 and left[2] < 0.4  # red side takes red
    assert right[2] > 0.6 and right[0] < 0.4  # blue side takes blue
    assert torch.isfinite(out).all() and out.min() >= 0 and out.max() <= 1


def test_texture_colour_fills_far_from_the_body_at_any_side():
    """The skip's fill reaches as far across the image at every side: at playback's larger sides a
    loose sleeve's edge beyond the fitted body takes the body's colour, not a fade to black."""
    from morf.avatar.renderer import TextureColour, fill_levels_for

    assert [fill_levels_for(s, s, 4) for s in (64, 256, 512, 640)] == [4, 4, 5, 6]
    assert fill_levels_for(64, 64, 0) == 0
    for side in (64, 256, 640):
        x = torch.zeros(1, 4, side, side)
        x[:, :3, :, : side // 4] = torch.tensor([0.2, 0.3, 0.6]).view(1, 3, 1, 1)
        x[:, 3, :, : side // 4] = 1.0
        colour = TextureColour(4)(x)
        far = colour[0, :, side // 2, side // 4 + side // 20]  # side/20 pixels off the body: 32 at 640
        torch.testing.assert_close(far, torch.tensor([0.2, 0.3, 0.6]), atol=0.02, rtol=0)


def test_rgb_skip_starts_at_the_texture_colour():
    """With rgb_skip the residual starts at zero: inside the mesh the colour is channels 0-2."""
    torch.manual_seed(0)
    r = UNetRenderer(RendererConfig(in_channels=8, width=8, depth=2, stem=2, skip_hidden=8, rgb_skip=True,
                                    premultiply=False))
    x = torch.rand(1, 8, 32, 32) * 0.8 + 0.1
    x[..., :4, :] = 0  # a band off the mesh
    out = r(x)
    torch.testing.assert_close(out[:, :3, 4:], x[:, :3, 4:])
    assert out[:, :3, :4].abs().sum() > 0  # off the mesh: filled from the neighbours, not black


def test_forward_parts_residual_is_what_the_network_adds_over_the_colour():
    """output RGB = (texture colour + residual) x mask."""
    torch.manual_seed(0)
    r = UNetRenderer(RendererConfig(in_channels=8, width=8, depth=2, stem=2, skip_hidden=8, rgb_skip=True))
    with torch.no_grad():
        r.last.weight.normal_(0, 0.1)  # a trained-looking head, so the residual is not zero
    x = torch.rand(2, 8, 32, 32) * 0.8 + 0.1
    out, residual = r.forward_parts(x)
    prob = torch.sigmoid(out[:, 3:])
    torch.testing.assert_close(out[:, :3], (r.colour(x) + residual) * prob)
    assert residual.abs().mean() > 1e-3
    torch.testing.assert_close(r(x), out)
    plain = UNetRenderer(RendererConfig(in_channels=8, width=8, depth=2, stem=2, skip_hidden=8))
    assert plain.forward_parts(x)[1] is None


def test_pointwise_matmul_is_the_same_function():
    """The exporter writes the half-resolution head's 1x1 convolutions as matrix products (so
    onnxruntime keeps them in the plain layout): the renderer's output does not change."""
    torch.manual_seed(0)
    r = UNetRenderer(RendererConfig(in_channels=6, width=8, depth=2, stem=4, skip_hidden=5, head_stride=2,
                                    rgb_skip=True)).eval()
    x = torch.rand(2, 6, 32, 32)
    with torch.no_grad():
        r.last.weight.normal_(0, 0.1)
        ref = r(x)
        r.pointwise_matmul = True
        torch.testing.assert_close(r(x), ref, atol=1e-5, rtol=1e-5)
        torch.testing.assert_close(r.pointwise(r.last, r.features(x)), F.conv2d(r.features(x), r.last.weight, r.last.bias),
                                   atol=1e-5, rtol=1e-5)
