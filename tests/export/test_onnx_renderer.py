"""ONNX renderers: fp32 graph against torch (tight), int8 against fp32 (PSNR bound), uint8 input."""

import warnings

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch

from morf.avatar.renderer import RendererConfig, UNetRenderer
from morf.export.onnx_renderer import export_fp32, export_int8
from morf.playback.composite import composite
from morf.raster.neural_raster import mark_coverage, to_layout
from morf.raster.texture_quant import quantize_texture, sinusoid_texture

H = W = 32


def _rasters(n, seed):
    """Smooth uint8 rasterizations with a background band (128), coverage marked as the GL rasterizer does."""
    q = quantize_texture(sinusoid_texture(16, H, seed=seed))
    out = []
    for k in range(n):
        x = np.roll(q.data, 3 * k, axis=1).transpose(2, 0, 1)[None].copy()
        x[..., : 6 + k, :] = 128
        out.append(mark_coverage(x, channel_axis=1))
    return out, q.scales


def _torch_reference(renderer, x, scales):
    with torch.no_grad():
        y = renderer(torch.from_numpy((x.astype(np.float32) - 128) * scales[None, :, None, None]))
    return torch.cat([y[:, :3], torch.sigmoid(y[:, 3:])], 1).numpy()


def _run(path, x, output="rgba", background=None):
    bg = np.zeros((1, 3, 1, 1), np.float32) if background is None else background
    return ort.InferenceSession(str(path), providers=["CPUExecutionProvider"]).run(
        [output], {"raster": x, "background": bg})[0]


@pytest.fixture(scope="module")
def renderers():
    torch.manual_seed(0)
    out = {"stem2": UNetRenderer(RendererConfig(width=8, depth=2, stem=2, skip_hidden=8)).eval(),
           "stem1": UNetRenderer(RendererConfig(width=8, depth=2, stem=1)).eval(),
           "skip": UNetRenderer(RendererConfig(width=8, depth=2, stem=2, skip_hidden=8, rgb_skip=True)).eval(),
           "half": UNetRenderer(RendererConfig(width=8, depth=2, stem=4, skip_hidden=8, rgb_skip=True,
                                               head_stride=2)).eval()}
    with torch.no_grad():  # a residual that is not zero, as after training
        for name in ("skip", "half"):
            out[name].last.weight[:3].normal_(0, 0.05)
    return out


@pytest.mark.parametrize("name", ["stem2", "stem1", "skip", "half"])
@pytest.mark.parametrize("layout", ["nhwc", "nchw", "planes"])
def test_fp32_matches_torch(tmp_path, renderers, name, layout):
    rasters, scales = _rasters(1, seed=1)
    export_fp32(renderers[name], scales, tmp_path / "r.onnx", layout, opaque=None)  # the torch mask as it is
    model = onnx.load(tmp_path / "r.onnx")
    assert model.graph.input[0].type.tensor_type.elem_type == onnx.TensorProto.UINT8
    # The per-channel dequantisation was folded into the convolutions: no Mul on the input path.
    assert "Mul" not in [n.op_type for n in model.graph.node[:4]]
    x = rasters[0]
    x[0, :, 1, 2:9] = 128
    x[0, 0, 1, 2:9] = 129  # on the body through the coverage byte only: the colour head's coverage must see it
    feed = to_layout(np.ascontiguousarray(x[0].transpose(1, 2, 0)), layout)
    np.testing.assert_allclose(_run(tmp_path / "r.onnx", feed), _torch_reference(renderers[name], x, scales), atol=2e-5)
    if name in ("skip", "half"):  # the coverage comes from one byte plane, not from 16 dequantised float planes
        ops = [n.op_type for n in model.graph.node]
        assert "ReduceSum" not in ops and "ReduceMax" not in ops and "Abs" in ops


def test_exported_fill_reaches_across_player_frames(tmp_path, renderers):
    """The fill's levels are constants of the traced graph: traced on a small sample, a 640 px
    frame got the sample's few levels and faded to black a few pixels from the body. The graph
    must fill as the torch renderer does at the frame's own size."""
    r = renderers["half"]
    q = quantize_texture(sinusoid_texture(16, 640, seed=4))
    x = np.full((1, 16, 640, 640), 128, np.uint8)
    x[0, :, 200:440, :160] = q.data.transpose(2, 0, 1)[:, 200:440, :160]
    mark_coverage(x, channel_axis=1)
    export_fp32(r, q.scales, tmp_path / "r.onnx", "nchw", opaque=None)
    got, ref = _run(tmp_path / "r.onnx", x), _torch_reference(r, x, q.scales)
    np.testing.assert_allclose(got, ref, atol=2e-5)
    assert np.abs(ref[0, :3, 320, 220]).sum() > 1e-3  # 60 px off the body: filled, not black


@pytest.mark.parametrize("name", ["stem2", "skip", "half"])
def test_int8_close_to_fp32(tmp_path, renderers, name):
    calib, scales = _rasters(4, seed=2)
    held, _ = _rasters(2, seed=5)
    r = renderers[name]
    export_fp32(r, scales, tmp_path / "f.onnx")
    export_int8(r, scales, tmp_path / "q.onnx", calib)
    nodes = onnx.load(tmp_path / "q.onnx").graph.node
    ops = {n.op_type for n in nodes}
    assert "QuantizeLinear" in ops and "DequantizeLinear" in ops
    if name != "stem2":  # the texture-colour fill stays float: nothing quantises its pooled colours
        pooled = {n.output[0] for n in nodes if n.op_type == "Resize" and n.name.startswith("/colour/")}
        assert pooled and not any(n.op_type == "QuantizeLinear" and n.input[0] in pooled for n in nodes)
    if name == "half":  # after head_low the head stays float, its 1x1 convolutions as MatMuls
        model = onnx.load(tmp_path / "q.onnx")
        floats = {t.name for t in model.graph.initializer if t.data_type == onnx.TensorProto.FLOAT}
        matmuls = [n for n in nodes if n.op_type == "MatMul"]
        assert len(matmuls) == 2 and all(n.input[0] in floats for n in matmuls)  # float weights, no QDQ
        produced = {o for n in matmuls for o in n.output}
        produced |= {o for n in nodes if produced.intersection(n.input) for o in n.output}  # + the bias Adds
        assert not any(n.op_type == "QuantizeLinear" and n.input[0] in produced for n in nodes)
    # the decoder's deepest block stays float: its convolutions read float weights, its outputs are not quantised
    deepest = [n for n in nodes if n.name.startswith("/up.0/") and n.op_type == "Conv"]
    assert deepest, [n.name for n in nodes if "up" in n.name][:10]
    model = onnx.load(tmp_path / "q.onnx")
    floats = {t.name for t in model.graph.initializer if t.data_type == onnx.TensorProto.FLOAT}
    assert all(n.input[1] in floats for n in deepest)
    assert not any(n.op_type == "QuantizeLinear" and n.input[0] in {d.output[0] for d in deepest} for n in nodes)
    dequantized = {n.output[0] for n in nodes if n.op_type == "DequantizeLinear"}
    next_block = [n for n in nodes if n.name.startswith("/up.1/") and n.op_type == "Conv"]
    assert next_block and all(n.input[1] in dequantized for n in next_block)  # quantised as before
    for x in held:
        a, b = _run(tmp_path / "f.onnx", x), _run(tmp_path / "q.onnx", x)
        psnr = -10 * np.log10(np.mean((a - b) ** 2))
        assert 30 < psnr < 120  # close, yet really quantised


def test_int8_keeps_the_calibration_closer_to_float(tmp_path, renderers, monkeypatch):
    """Both activation ranges are tried; the one whose int8 graph scores higher is written, and the
    model and the return value say which."""
    import morf.export.onnx_renderer as onnx_renderer

    calib, scales = _rasters(4, seed=2)
    real = onnx_renderer.calibration_score
    scores = iter([20.0, 35.0])  # percentile, then minmax: the full range wins here

    def scored(q8_path, rasters, reference):
        assert len(rasters) == len(reference) == 1  # every 4th of the 4 calibration views
        assert 10 < real(q8_path, rasters, reference) < 120  # the real score of a real int8 graph
        return next(scores)

    monkeypatch.setattr(onnx_renderer, "calibration_score", scored)
    chosen = export_int8(renderers["half"], scales, tmp_path / "q.onnx", calib)
    assert chosen == {"calibration": "minmax", "scores_db": {"percentile": 20.0, "minmax": 35.0},
                      "native_tail": None}  # the "nchw" layout: the player's compiled tail reads "nhwc" only
    meta = {p.key: p.value for p in onnx.load(tmp_path / "q.onnx").metadata_props}
    assert meta["int8_calibration"].startswith("minmax (percentile 20.0 dB, minmax 35.0 dB)")


@pytest.mark.parametrize("stem", [2, 1])
def test_int8_keeps_colours_under_large_mask_logits(tmp_path, stem):
    """A trained renderer's mask logit spans tens of units while RGB spans one: int8 stays close."""
    torch.manual_seed(3)
    r = UNetRenderer(RendererConfig(width=8, depth=2, stem=stem, skip_hidden=8)).eval()
    with torch.no_grad():
        r.last.weight[3] *= 400.0  # logits of about +-30, as after training with a Dice loss
        r.last.bias[3] = 0.0
    calib, scales = _rasters(4, seed=2)
    held, _ = _rasters(2, seed=5)
    export_fp32(r, scales, tmp_path / "f.onnx")
    export_int8(r, scales, tmp_path / "q.onnx", calib)
    for x in held:
        with torch.no_grad():
            logit = r(torch.from_numpy((x.astype(np.float32) - 128) * scales[None, :, None, None]))[:, 3]
        assert logit.abs().max() > 10  # the logits really are large
        a, b = _run(tmp_path / "f.onnx", x), _run(tmp_path / "q.onnx", x)
        psnr = -10 * np.log10(np.mean((a[:, :3] - b[:, :3]) ** 2))
        assert psnr > 30


def test_small_renderer_reads_first_channels(tmp_path):
    torch.manual_seed(1)
    r = UNetRenderer(RendererConfig(in_channels=8, width=8, depth=2, stem=2, skip_hidden=8)).eval()
    rasters, scales = _rasters(1, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the input scale must fold: no float Mul + Slice on the input
        export_fp32(r, scales, tmp_path / "r.onnx")
    g = onnx.load(tmp_path / "r.onnx").graph
    deq = next(n for n in g.node if n.op_type == "DequantizeLinear" and n.input[0] == "raster")
    assert {n.op_type for n in g.node if deq.output[0] in n.input} == {"Conv"}  # folded: convs read it directly
    x = rasters[0]
    with torch.no_grad():
        y = r(torch.from_numpy((x[:, :8].astype(np.float32) - 128) * scales[None, :8, None, None]))
    ref = torch.cat([y[:, :3], torch.sigmoid(y[:, 3:])], 1).numpy()
    np.testing.assert_allclose(_run(tmp_path / "r.onnx", x), ref, atol=2e-5)


@pytest.mark.parametrize("precision", ["fp32", "int8"])
def test_graph_composites_like_numpy(tmp_path, renderers, precision):
    """The graph's ``image`` output is the numpy composite of its ``rgba`` output (colour and image
    backgrounds), channels last, with the same rounding."""
    rasters, scales = _rasters(3, seed=4)
    path = tmp_path / "r.onnx"
    if precision == "fp32":
        export_fp32(renderers["stem2"], scales, path, "nhwc")
    else:
        export_int8(renderers["stem2"], scales, path, rasters, "nhwc")
    x = to_layout(np.ascontiguousarray(rasters[1][0].transpose(1, 2, 0)), "nhwc")
    rgba = _run(path, x)
    colour = np.array([20, 200, 90], np.float32)
    img = np.random.default_rng(0).integers(0, 256, (H, W, 3)).astype(np.uint8)
    for bg, feed in [(colour, colour.reshape(1, 3, 1, 1)), (img, img.astype(np.float32).transpose(2, 0, 1)[None])]:
        out = _run(path, x, "image", np.ascontiguousarray(feed))
        assert out.shape == (1, H, W, 3) and out.dtype == np.uint8
        ref = composite(rgba, bg)
        assert np.abs(out[0].astype(int) - ref).max() <= 1  # float rounding at .5 only
        assert (out[0] != ref).mean() < 0.01


def test_the_composite_reads_an_rgba_it_did_not_see_concatenated():
    """A graph whose ``rgba`` is not a Concat of RGB and mask (here an Identity of an input) is
    composited through a Split, to the same bytes as the numpy composite."""
    from onnx import TensorProto, helper

    from morf.export.onnx_graph import append_composite

    g = helper.make_graph([helper.make_node("Identity", ["x"], ["rgba"])], "g",
                          [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 4, 8, 8])],
                          [helper.make_tensor_value_info("rgba", TensorProto.FLOAT, [1, 4, 8, 8])])
    model = append_composite(helper.make_model(g, opset_imports=[helper.make_opsetid("", 17)]))
    assert any(n.op_type == "Split" for n in model.graph.node)
    rng = np.random.default_rng(1)
    mask = rng.uniform(0, 1, (1, 1, 8, 8)).astype(np.float32)
    rgba = np.concatenate([rng.uniform(0, 1, (1, 3, 8, 8)).astype(np.float32) * mask, mask], 1)
    colour = np.array([20, 200, 90], np.float32)
    out = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"]).run(
        ["image"], {"x": rgba, "background": colour.reshape(1, 3, 1, 1)})[0]
    assert np.abs(out[0].astype(int) - composite(rgba, colour)).max() <= 1


def test_the_mask_is_held_at_one_inside_the_body(tmp_path, renderers):
    """Playback holds the mask at 1 a few pixels inside the body mesh (a hole there is never
    right); near the outline and off the body the renderer's own mask stays."""
    from morf.export.onnx_graph import OPAQUE_MARGIN_PX

    r = renderers["half"]
    rasters, scales = _rasters(1, seed=3)
    x = rasters[0]
    x[:, :, :, :] = 128  # off the body everywhere ...
    x[:, :, 4:28, 4:28] = np.random.default_rng(0).integers(60, 200, (1, 16, 24, 24), dtype=np.uint8)  # ... but a square
    mark_coverage(x, channel_axis=1)
    bias = float(r.last.bias[3].detach())
    with torch.no_grad():
        r.last.bias[3] = -6.0  # a renderer whose mask is off everywhere
    try:
        export_fp32(r, scales, tmp_path / "o.onnx", opaque=OPAQUE_MARGIN_PX)
        export_fp32(r, scales, tmp_path / "p.onnx", opaque=None)
        held, plain = _run(tmp_path / "o.onnx", x), _run(tmp_path / "p.onnx", x)  # the default layout, nchw
    finally:
        with torch.no_grad():
            r.last.bias[3] = bias
    m = OPAQUE_MARGIN_PX
    inside = (slice(None), slice(4 + m, 28 - m), slice(4 + m, 28 - m))
    assert plain[0, 3].max() < 0.5 and np.all(held[0, 3][inside[1:]] == 1.0)
    edge = held[0, 3].copy()
    edge[inside[1:]] = plain[0, 3][inside[1:]]
    np.testing.assert_allclose(edge, plain[0, 3], atol=1e-6)  # the outline band and the background: unchanged


def test_the_calibrator_is_fed_a_few_views_at_a_time(tmp_path, renderers, monkeypatch):
    """The percentile calibration keeps every activation of what it is fed in memory, so the views
    go in equal chunks of at most CALIBRATION_CHUNK; min-max ranges come out as from one pass."""
    import morf.export.onnx_renderer as onnx_renderer

    assert [onnx_renderer.chunk_size(n) for n in (1, 2, 3, 4, 5, 6, 7, 8, 24)] == [1, 2, 3, 4, 1, 3, 1, 4, 4]
    calib, scales = _rasters(6, seed=2)
    fed = []
    set_range = onnx_renderer._Calibration.set_range

    def spy(self, start_index, end_index):
        fed.append((start_index, end_index))
        set_range(self, start_index, end_index)

    monkeypatch.setattr(onnx_renderer._Calibration, "set_range", spy)
    export_int8(renderers["half"], scales, tmp_path / "q.onnx", calib)
    assert fed == [(0, 3), (3, 6)] * 2  # both calibrations, two chunks of three views each
    monkeypatch.setattr(onnx_renderer, "CALIBRATIONS", (("minmax", "MinMax", {}),))
    export_int8(renderers["half"], scales, tmp_path / "chunked.onnx", calib)
    monkeypatch.setattr(onnx_renderer, "chunk_size", lambda n: n)
    export_int8(renderers["half"], scales, tmp_path / "whole.onnx", calib)
    graphs = [onnx.load(tmp_path / f).graph.SerializeToString() for f in ("chunked.onnx", "whole.onnx")]
    assert graphs[0] == graphs[1]
