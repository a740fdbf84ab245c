"""Renderer equalisation for int8: same function, balanced activation ranges."""

import pytest
import torch

from morf.avatar.renderer import RendererConfig, UNetRenderer
from morf.export.equalize import _max_abs, equalize_renderer


def _imbalanced(stem, head_stride=1):
    """A renderer whose internal ranges are as lopsided as a trained one's (its function is a
    random renderer's: every imbalance is compensated by the consuming convolution)."""
    torch.manual_seed(0)
    r = UNetRenderer(RendererConfig(width=8, depth=2, stem=stem, skip_hidden=8, head_stride=head_stride)).eval()
    with torch.no_grad():
        c = r.up[0][2].out_channels
        r.up[0][2].weight *= 20.0
        r.up[0][2].bias *= 20.0
        r.up[1][0].weight[:, :c] /= 20.0
        r.up[1][0].weight[3] *= 30.0
        r.up[1][0].bias[3] *= 30.0
        r.up[1][2].weight[:, 3] /= 30.0
        if stem > 1:
            c = r.head_low[0].out_channels
            r.head_low[0].weight *= 60.0
            r.head_low[0].bias *= 60.0
            r.head[0].weight[:, :c] /= 60.0
            r.head[0].weight[2] *= 40.0
            r.head[0].bias[2] *= 40.0
            if head_stride > 1:
                r.head_x.weight[2] *= 40.0
            r.head[2].weight[:, 2] /= 40.0
    return r


@pytest.mark.parametrize("stem,head_stride", [(2, 1), (1, 1), (4, 2)])
def test_equalized_renderer_computes_the_same_function(stem, head_stride):
    r = _imbalanced(stem, head_stride)
    xs = [torch.rand(1, 16, 32, 32) * 2 - 1 for _ in range(3)]
    e = equalize_renderer(r, xs)
    with torch.no_grad():
        for x in xs + [torch.rand(1, 16, 32, 32) * 2 - 1]:
            a, b = r(x), e(x)
            assert torch.allclose(a, b, rtol=1e-4, atol=1e-4 * float(a.abs().max()))
    assert e is not r and not torch.equal(e.up[0][2].weight, r.up[0][2].weight)  # the original is untouched


def test_ranges_are_balanced_after_equalisation():
    r = _imbalanced(2)
    xs = [torch.rand(1, 16, 32, 32) * 2 - 1 for _ in range(3)]
    e = equalize_renderer(r, xs)
    before = _max_abs(r, {"low": r.head_low, "act": r.head[1]}, xs, per_channel=True)
    after = _max_abs(e, {"low": e.head_low, "act": e.head[1]}, xs, per_channel=True)
    assert float(before["low"].max()) > 5.0
    assert abs(float(after["low"].max()) - 1.0) < 1e-3  # matches the raw rasterization's [-1, 1]
    spread = lambda v: float(v.max() / v.clamp_min(1e-6).min())  # noqa: E731
    # every hidden channel of the head spans the same range (up to the 100x cap on a rescaling)
    assert spread(before["act"]) > 20
    assert spread(after["act"]) <= max(1.01, spread(before["act"]) / 100 * 1.01)
    # skips and the upsampled branch of each decoder concatenation share one magnitude
    for i, skip in enumerate([e.down[0], e.enc0]):
        src = e.down[1] if i == 0 else e.up[0]
        m = _max_abs(e, {"h": src, "s": skip}, xs)
        assert abs(float(m["h"] / m["s"]) - 1.0) < 1e-3


def test_int8_of_an_imbalanced_renderer_stays_close_to_fp32(tmp_path, monkeypatch):
    import numpy as np
    import onnxruntime as ort

    import morf.export.equalize as eq
    from morf.export.onnx_renderer import export_fp32, export_int8
    from morf.raster.texture_quant import quantize_texture, sinusoid_texture

    r = _imbalanced(2)
    q = quantize_texture(sinusoid_texture(16, 32, seed=4))
    rasters = []
    for k in range(6):
        x = np.roll(q.data, 5 * k, axis=1).transpose(2, 0, 1)[None].copy()
        x[..., : 4 + k, :] = 128
        rasters.append(x)
    export_fp32(r, q.scales, tmp_path / "f.onnx")

    def psnr_int8(name):
        export_int8(r, q.scales, tmp_path / name, rasters[:4])
        run = lambda p, x: ort.InferenceSession(str(p), providers=["CPUExecutionProvider"]).run(["rgba"], {"raster": x, "background": np.zeros((1, 3, 1, 1), np.float32)})[0]  # noqa: E731
        err = np.mean([np.mean((run(tmp_path / "f.onnx", x)[:, :3] - run(tmp_path / name, x)[:, :3]) ** 2) for x in rasters[4:]])
        return -10 * np.log10(err)

    equalized = psnr_int8("q.onnx")
    monkeypatch.setattr(eq, "equalize_renderer", lambda renderer, inputs, **kw: renderer)
    plain = psnr_int8("q_plain.onnx")
    print(f"int8 vs fp32: {equalized:.1f} dB equalised, {plain:.1f} dB without")
    assert equalized > plain + 3
