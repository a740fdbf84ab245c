"""The renderer's full-resolution tail as one compiled pass (morf.export.compiled_tail): the exporter
finds it in the graphs it writes, and the player's images through it are the whole graph's."""

import json

import numpy as np
import onnxruntime as ort
import pytest

from morf.playback.graph_outputs import cut_graph
from morf.export.compiled_tail import HeadStage, TailShader, TailSpec, reference_head, reference_tail
from morf.playback.native_tail import TailRenderer, spec_for
from morf.playback.onnx_renderer import OnnxRenderer, background_planes
from morf.playback.player import Player
from morf.raster.camera_paths import front_camera

SIZE = 128


@pytest.fixture(scope="module")
def cpu_avatar(tmp_path_factory, body_model):
    """A synthetic avatar with the `cpu` preset's renderer (head at half resolution, colour skip),
    its last layer randomised so the residual and the mask vary over the image."""
    import torch

    from morf.avatar.renderer import UNetRenderer
    from morf.export.synthetic import build_synthetic_avatar
    from morf.train.config import preset

    torch.manual_seed(3)
    renderer = UNetRenderer(preset("cpu").renderer).eval()
    with torch.no_grad():
        renderer.last.weight.normal_(0.0, 0.3)
        renderer.last.bias[3] = 0.5
    out = tmp_path_factory.mktemp("cpu_avatar") / "avatar"
    build_synthetic_avatar(out, body_model=body_model, renderer=renderer, image_size=SIZE, calibration_views=3,
                           heldout_views=2)
    return out


def _pose(seed):
    rng = np.random.default_rng(seed)
    rot = (rng.normal(size=(104, 3)) * 0.15).astype(np.float32)
    rot[0] = (0.0, 0.0, 0.3 + seed)
    return rot, np.array([0.02, 0.0, 0.0], np.float32)


def _levels(a, b):
    d = np.abs(a.astype(np.int16) - b.astype(np.int16))
    return int(d.max()), float((d > 0).mean())


def test_the_exporter_records_a_checked_tail_for_both_graphs(cpu_avatar):
    manifest = json.loads((cpu_avatar / "manifest.json").read_text())
    tails = manifest["renderer"]["native_tail"]
    assert set(tails) == {"int8", "fp32"}
    for precision, entry in tails.items():
        spec = spec_for(manifest, precision)
        assert spec is not None and spec.opaque_margin == 4 and spec.coverage_channel == 0
        assert entry["check"]["views"] == 2 and entry["check"]["max_levels"] <= 2
        assert entry["check"]["share_differing"] <= 1e-3
    assert tails["fp32"]["logit_scale"] == 1.0 and tails["int8"]["logit_scale"] != 1.0  # int8 maps the mask channel
    # the int8 graph's half-resolution head ends in constants the pass can take over; the fp32 graph's does not
    stage = spec_for(manifest, "int8").head_stage
    assert stage is not None and len(stage.weight) == 4 and len(stage.weight[0]) == 16 and stage.alpha == pytest.approx(0.2)
    assert spec_for(manifest, "fp32").head_stage is None


@pytest.mark.parametrize("precision", ["int8", "fp32"])
@pytest.mark.parametrize("background", ["colour", "image"])
def test_the_player_through_the_tail_matches_the_whole_graph(cpu_avatar, precision, background):
    bg = (20, 140, 230) if background == "colour" else \
        np.random.default_rng(5).integers(0, 256, (SIZE, SIZE, 3)).astype(np.uint8)
    frames = {}
    for native in (True, False):
        with Player(cpu_avatar, size=SIZE, precision=precision, background=bg, native=native) as p:
            assert isinstance(p.renderer, TailRenderer if native else OnnxRenderer)
            frames[native] = [p.render(*_pose(s), front_camera(SIZE, yaw_deg=40.0 * s)) for s in range(3)]
            if native:
                assert set(p.last_timings) >= {"graph_ms", "tail_ms", "renderer_ms"}
    for a, b in zip(frames[True], frames[False]):
        worst, share = _levels(a, b)
        assert worst <= 2 and share <= 1e-3, (worst, share)
    # the frames show the body, the fill around it and the residual (not two flat images compared)
    assert frames[False][0].std() > 15


def test_the_compiled_pass_is_the_documented_function():
    """Against the numpy reference (float64) on random inputs, edges and a fully covered block included."""
    rng = np.random.default_rng(0)
    H = W = 96
    raster = rng.integers(100, 160, (1, H, W, 16)).astype(np.uint8)
    raster[0, :, :, 0][rng.random((H, W)) < 0.3] = 128  # scattered background pixels
    raster[0, 20:60, 30:70, 0] = 140  # a block well covered: the opaque body holds its mask at 1
    raster[0, :, :3, 0] = 128  # and an uncovered border
    head = rng.normal(0, 1.5, (1, 4, H // 2, W // 2)).astype(np.float32)
    fill = np.abs(rng.normal(0.3, 0.2, (1, 4, H // 2, W // 2))).astype(np.float32)
    fill[0, 3, :5] = 0.0  # weights under the floor
    spec = TailSpec(head="h", fill="f", colour_scale=(0.01, 0.02, 0.015), zero_point=128, coverage_channel=0,
                    logit_scale=3.0, logit_offset=-1.0, weight_min=1e-4, opaque_margin=3)
    for bg in (background_planes((30, 60, 250), H), background_planes(rng.integers(0, 256, (H, W, 3)), H)):
        got = TailShader(spec)(raster, head, fill, bg)
        want = reference_tail(spec, raster, head, fill, bg)
        worst, share = _levels(got, want)
        assert worst <= 1 and share < 0.01, (worst, share)
    with pytest.raises(ValueError, match="do not match"):
        TailShader(spec)(raster, head[:, :, :10], fill, bg)


@pytest.mark.parametrize("skip_dtype", [np.uint8, np.float32])
def test_the_compiled_head_stage_is_the_documented_function(skip_dtype):
    rng = np.random.default_rng(1)
    low = rng.normal(0, 1, (1, 16, 24, 20)).astype(np.float32)
    skip = (rng.integers(0, 256, (1, 16, 48, 40)) if skip_dtype == np.uint8 else rng.normal(0, 1, (1, 16, 48, 40)))
    stage = HeadStage(low="l", skip="s", skip_scale=0.03 if skip_dtype == np.uint8 else 1.0,
                      skip_zero_point=131 if skip_dtype == np.uint8 else 0, alpha=0.2,
                      weight=tuple(tuple(r) for r in rng.normal(0, 0.5, (4, 16)).tolist()),
                      bias=tuple(rng.normal(0, 0.1, 4).tolist()))
    spec = TailSpec(head="h", fill="f", colour_scale=(0.01,) * 3, zero_point=128, coverage_channel=0, logit_scale=1.0,
                    logit_offset=0.0, weight_min=1e-4, opaque_margin=0, head_stage=stage)
    got = TailShader(spec).head(low, skip.astype(skip_dtype))
    want = reference_head(stage, low, skip.astype(skip_dtype))
    assert got.shape == (1, 4, 48, 40) and np.allclose(got, want, atol=1e-4)
    assert TailSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec  # through the manifest and back


def test_the_tail_can_be_turned_off(cpu_avatar, monkeypatch):
    monkeypatch.setenv("MORF_NATIVE_TAIL", "0")
    with Player(cpu_avatar, size=SIZE) as p:
        assert isinstance(p.renderer, OnnxRenderer)


def test_graphs_without_the_tail_play_whole(tiny_avatar):
    """The coverage stand-in renderer has no colour skip: no spec, the whole graph plays."""
    manifest = json.loads((tiny_avatar / "manifest.json").read_text())
    assert "native_tail" not in manifest["renderer"]
    with Player(tiny_avatar, size=SIZE) as p:
        assert isinstance(p.renderer, OnnxRenderer)


def test_a_spec_of_another_kind_is_ignored(cpu_avatar):
    manifest = json.loads((cpu_avatar / "manifest.json").read_text())
    manifest["renderer"]["native_tail"]["int8"]["kind"] = "something newer"
    assert spec_for(manifest, "int8") is None and spec_for(manifest, "fp32") is not None
    manifest["renderer"]["input_layout"] = "nchw"
    assert spec_for(manifest, "fp32") is None


def test_cut_graph_keeps_what_the_named_tensors_need(cpu_avatar):
    manifest = json.loads((cpu_avatar / "manifest.json").read_text())
    spec = spec_for(manifest, "int8")
    data = (cpu_avatar / "renderer_int8.onnx").read_bytes()
    s = ort.InferenceSession(cut_graph(data, (spec.head, spec.fill)), providers=["CPUExecutionProvider"])
    assert [i.name for i in s.get_inputs()] == ["raster"]  # the background input went with the compositing
    assert [o.name for o in s.get_outputs()] == [spec.head, spec.fill]
    head, fill = s.run(None, {"raster": np.full((1, SIZE, SIZE, 16), 128, np.uint8)})
    assert head.shape == fill.shape == (1, 4, SIZE // 2, SIZE // 2)
    with pytest.raises(ValueError, match="no tensor named"):
        cut_graph(data, ("not_in_the_graph",))


def test_the_benchmark_profiles_the_graph_the_player_runs(cpu_avatar):
    from morf.bench.render import graph_profile

    with Player(cpu_avatar, size=SIZE) as p:
        prof = graph_profile(p, p.rasterize(*_pose(0), front_camera(SIZE)), runs=2)
    assert prof.composite_share is None  # the compositing runs in the compiled pass, not in the graph
    assert "QLinearConv" in prof.ops and "MaxPool" not in prof.ops  # the opaque body's pools went with the tail


def test_the_tail_plays_without_torch_or_onnx(cpu_avatar):
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent("""
        import sys
        sys.modules["torch"] = None  # any import of torch or of the onnx package now fails
        sys.modules["onnx"] = None
        import numpy as np
        from morf.playback.player import Player
        from morf.raster.camera_paths import front_camera
        with Player(sys.argv[1], size=128) as p:
            img = p.render(np.zeros((p.avatar.skeleton.num_bones, 3)), np.zeros(3), front_camera(128))
            print(type(p.renderer).__name__, img.shape)
    """)
    r = subprocess.run([sys.executable, "-c", script, str(cpu_avatar)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split()[0] == "TailRenderer"


def test_the_exporter_records_no_tail_that_disagrees_with_the_graph(cpu_avatar, monkeypatch):
    """The check is what stands between a wrong pass and the player: a pass off by a few levels on
    a few pixels gets no manifest entry, and the player then runs the whole graph."""
    from morf.export import native_tail_spec
    from morf.export.compiled_tail import TailShader

    raster = np.full((1, SIZE, SIZE, 16), 128, np.uint8)
    raster[0, 40:90, 50:80] = 150  # a block of body
    path = cpu_avatar / "renderer_int8.onnx"
    spec = spec_for(json.loads((cpu_avatar / "manifest.json").read_text()), "int8")
    assert native_tail_spec.native_tail_entry(path, spec, [raster]) is not None
    right = TailShader.run

    def off(self, cut, raster, background, out=None):
        img = right(self, cut, raster, background, out=out).copy()
        img[:4, :4] = img[:4, :4] // 2 + 3  # 48 of 49 152 pixel channels: far beyond rounding
        return img

    monkeypatch.setattr(TailShader, "run", off)
    assert native_tail_spec.native_tail_entry(path, spec, [raster]) is None
    assert native_tail_spec.native_tail_entry(path, None, [raster]) is None  # a graph its exporter gave no tail


def test_the_tail_is_the_exporters_word_not_read_back_from_node_names(cpu_avatar):
    """The cut tensors are the ones the exporter named, the constants the ones it set; the finished
    graphs keep the named tensors inside (the player cuts there) but only their own two outputs."""
    import onnx

    manifest = json.loads((cpu_avatar / "manifest.json").read_text())
    for precision, name in (("fp32", "renderer.onnx"), ("int8", "renderer_int8.onnx")):
        model = onnx.load(str(cpu_avatar / name))
        assert [o.name for o in model.graph.output] == ["rgba", "image"]
        made = {t for n in model.graph.node for t in n.output}
        spec = spec_for(manifest, precision)
        assert spec.head == "tail_head" and set(spec.cut) <= made
    scales = np.load(cpu_avatar / "texture.npz")["scales"]
    int8 = spec_for(manifest, "int8")
    assert int8.colour_scale == pytest.approx(tuple(scales[:3]), rel=1e-6)
    assert int8.zero_point == 128 and int8.weight_min == pytest.approx(1e-4)
