import dataclasses
import json

import numpy as np
import pytest
import torch

from morf.errors import InputError, TrainingDiverged
from morf.pipeline.control import StageControl, StopRequested
from morf.train.config import preset
from morf.train.loop import train_avatar
from morf.train.run_dir import RunDir
from morf.train.trained_avatar import load_trained_avatar
from morf.train.trainer import Trainer


def tiny(method, **kw):
    base = dict(resolution=32, steps=40, batch_size=2, texture_size=32, inpaint_steps=0, report_every=5,
                log_every=5, device="cpu")
    base.update(kw)
    return preset("tiny", method, **base)


def texture_init(cfg):
    g = torch.Generator().manual_seed(0)
    return torch.randn(cfg.texture_channels, cfg.texture_size, cfg.texture_size, generator=g) * 0.5


@pytest.mark.parametrize("method", ["morf", "stylepeople", "anr"])
def test_tiny_run_loss_decreases(method, frames_factory):
    torch.manual_seed(0)
    frames = frames_factory()
    # random texture init (no projected colours here), so its channels 0-2 are free to learn
    cfg = tiny(method, steps=100, w_gan=0.0, lr_renderer=3e-3, freeze_colour=False)
    tr = Trainer(cfg, frames, texture_init(cfg))
    hist = [tr.train_step()[0]["l1"] for _ in range(cfg.steps)]
    assert np.mean(hist[-10:]) < 0.8 * np.mean(hist[:5])
    if method == "morf":
        assert tr.model.warp is not None
    else:
        assert tr.model.warp is None


def test_frozen_colour_stays_as_it_started(frames_factory):
    cfg = tiny("morf", w_gan=0.0, freeze_colour=True)
    tr = Trainer(cfg, frames_factory(), texture_init(cfg))
    tex0 = tr.model.texture.texture.detach().clone()
    for _ in range(5):
        tr.train_step()
    tex = tr.model.texture.texture.detach()
    assert torch.equal(tex[:3], tex0[:3]) and not torch.equal(tex[3:], tex0[3:])
    plain = cfg.replace(renderer=dataclasses.replace(cfg.renderer, rgb_skip=False))  # no colour channels: all learn
    tr = Trainer(plain, frames_factory(), texture_init(plain))
    tex0 = tr.model.texture.texture.detach().clone()
    tr.train_step()
    assert not torch.equal(tr.model.texture.texture[:3], tex0[:3])


def test_residual_penalty_keeps_the_residual_small(frames_factory):
    """w_residual adds an L1 term on what the renderer adds over the colour channels; trained with
    it, that residual ends smaller than trained without it (same seed, same steps)."""
    sizes = []
    for w in (0.0, 5.0):
        torch.manual_seed(0)
        cfg = tiny("morf", steps=40, w_gan=0.0, lr_renderer=3e-3, w_residual=w)
        tr = Trainer(cfg, frames_factory(), texture_init(cfg))
        for _ in range(cfg.steps):
            losses, out, _ = tr.train_step()
        assert ("residual" in losses) == (w > 0)
        sizes.append(out.residual.abs().mean().item())
    assert sizes[1] < 0.5 * sizes[0]


def test_anr_alternates_texture_and_renderer(frames_factory):
    cfg = tiny("anr", w_gan=0.0)
    tr = Trainer(cfg, frames_factory(), texture_init(cfg))
    tex0 = tr.model.texture.texture.detach().clone()
    ren0 = [p.detach().clone() for p in tr.model.renderer.parameters()]
    tr.train_step()  # step 0: texture only
    assert not torch.equal(tr.model.texture.texture, tex0)
    assert all(torch.equal(a, b) for a, b in zip(ren0, tr.model.renderer.parameters()))
    tex1 = tr.model.texture.texture.detach().clone()
    tr.train_step()  # step 1: renderer only
    assert torch.equal(tr.model.texture.texture, tex1)
    assert not all(torch.equal(a, b) for a, b in zip(ren0, tr.model.renderer.parameters()))


def test_full_run_with_progress_writes_avatar(frames_factory, tmp_path):
    frames = frames_factory()
    cfg = tiny("morf", steps=10)
    seen = []
    res = train_avatar(frames, tmp_path / "run", cfg, texture_init(cfg), StageControl(seen.append),
                       shape=torch.full((1, 6), 0.5))
    assert res.step == 10 and res.resumed_from == 0
    trains = [p for p in seen if p.images]
    assert trains and {"render", "warp"} <= set(trains[-1].images)
    assert trains[-1].images["render"].shape == (32, 32, 3) and trains[-1].images["render"].dtype == np.uint8
    run = RunDir(tmp_path / "run")
    assert json.loads(run.config_path.read_text())["method"] == "morf"
    assert [m["step"] for m in run.read_metrics()] == [5, 10]
    assert "structure from the SSIM term" in run.log_path.read_text()  # no VGG, no adversarial terms
    assert "bfloat16" not in run.log_path.read_text()  # the tiny preset does not ask for it
    av = load_trained_avatar(run.root)
    assert av.texture.shape == (cfg.texture_channels, 32, 32) and av.method == "morf"
    rgb, mask = av.render(torch.rand(1, 32, 32, 2), torch.ones(1, 32, 32, dtype=torch.bool))
    assert rgb.shape == (1, 3, 32, 32) and mask.shape == (1, 1, 32, 32)
    # a finished run is not trained again
    assert train_avatar(frames, run.root, cfg, texture_init(cfg)).resumed_from == 10


def test_a_train_result_is_json_ready(tmp_path):
    from morf.train.loop import TrainResult

    res = TrainResult(tmp_path / "run", 10, {"l1": 0.25}, 1.5, 4)
    d = res.to_dict()
    assert d == {"run_dir": str(tmp_path / "run"), "step": 10, "losses": {"l1": 0.25}, "train_minutes": 1.5,
                 "resumed_from": 4}
    assert json.loads(json.dumps(d)) == d and d["losses"] is not res.losses


def test_stop_then_resume_continues_from_step_k(frames_factory, tmp_path):
    frames = frames_factory()
    cfg = tiny("morf", steps=12, checkpoint_minutes=1e6)
    k = 5
    control = StageControl()

    def on_progress(p):
        if p.step >= k:
            control.stop()

    control._on_progress = on_progress
    with pytest.raises(StopRequested):
        train_avatar(frames, tmp_path / "run", cfg.replace(report_every=1), texture_init(cfg), control)
    run = RunDir(tmp_path / "run")
    assert run.load_checkpoint()["step"] == k and not run.is_done
    with pytest.raises(InputError):  # a different config is refused on resume
        train_avatar(frames, run.root, cfg.replace(steps=99), texture_init(cfg))
    res = train_avatar(frames, run.root, cfg.replace(report_every=1), texture_init(cfg))
    assert res.resumed_from == k and res.step == 12
    # identical to an uninterrupted run: same data order and state
    straight = train_avatar(frames, tmp_path / "straight", cfg.replace(report_every=1), texture_init(cfg))
    a = load_trained_avatar(run.root).texture
    b = load_trained_avatar(straight.run_dir).texture
    assert torch.allclose(a, b, atol=1e-5)


def test_lr_decay_schedule_shape():
    cfg = tiny("morf", steps=100, lr_decay_start=0.5, lr_decay_floor=0.1)
    f = [cfg.lr_factor(s) for s in range(101)]
    assert f[0] == f[50] == 1.0 and f[100] == pytest.approx(0.1)
    assert f[75] == pytest.approx(0.55) and all(a >= b for a, b in zip(f[50:], f[51:]))
    assert tiny("morf", steps=100).lr_factor(100) == 1.0  # off by default
    with pytest.raises(InputError):
        tiny("morf", lr_decay_floor=0.0).validate()


def test_lr_decay_sets_rates_and_composes_with_recovery_halving(frames_factory):
    cfg = tiny("morf", steps=10, lr_decay_start=0.0, lr_decay_floor=0.5, w_gan=0.02)
    tr = Trainer(cfg, frames_factory(), texture_init(cfg))
    for _ in range(5):
        tr.train_step()
    tr.scale_learning_rates(0.5)  # as a rollback does
    tr.train_step()  # applies the factor of step 5
    for opt in (tr.opt, tr.opt_d):
        for g in opt.param_groups:
            assert g["base_lr"] > 0 and g["lr"] == pytest.approx(g["base_lr"] * cfg.lr_factor(5))
    lr = {g["name"]: g["lr"] for g in tr.opt.param_groups}
    assert lr["renderer"] == pytest.approx(cfg.lr_renderer * 0.5 * cfg.lr_factor(5))
    # a checkpoint keeps the base rates: a restored trainer continues the same schedule
    tr2 = Trainer(cfg, frames_factory(), texture_init(cfg))
    tr2.load_state_dict(tr.state_dict())
    assert [g["base_lr"] for g in tr2.opt.param_groups] == [g["base_lr"] for g in tr.opt.param_groups]


def _stopped_at_5_and_resumed(frames, cfg, tmp_path):
    """The avatars of a run stopped after step 5 and resumed (``tmp_path/run``) and of the same run
    uninterrupted."""
    control = StageControl()
    control._on_progress = lambda p: control.stop() if p.step >= 5 else None
    with pytest.raises(StopRequested):
        train_avatar(frames, tmp_path / "run", cfg, texture_init(cfg), control)
    train_avatar(frames, tmp_path / "run", cfg, texture_init(cfg))
    straight = train_avatar(frames, tmp_path / "straight", cfg, texture_init(cfg))
    return load_trained_avatar(tmp_path / "run"), load_trained_avatar(straight.run_dir)


def test_resume_with_lr_decay_matches_an_uninterrupted_run(frames_factory, tmp_path):
    cfg = tiny("morf", steps=12, checkpoint_minutes=1e6, report_every=1, lr_decay_start=0.25)
    a, b = _stopped_at_5_and_resumed(frames_factory(), cfg, tmp_path)
    assert torch.allclose(a.texture, b.texture, atol=1e-5)


def test_weight_average_follows_its_recursion(frames_factory):
    cfg = tiny("morf", steps=10, ema_decay=0.5)
    tr = Trainer(cfg, frames_factory(), texture_init(cfg))
    expected = tr.model.texture.texture.detach().clone()
    for t in range(3):
        tr.train_step()
        d = min(0.5, (1 + t) / (10 + t))  # warm-up: 0.1, 0.18, 0.25
        expected = d * expected + (1 - d) * tr.model.texture.texture.detach()
    assert torch.allclose(tr.ema[0], expected, atol=1e-6)
    assert not torch.allclose(tr.ema[0], tr.model.texture.texture)
    assert tr.use_averaged_weights() and torch.equal(tr.model.texture.texture, tr.ema[0])
    assert Trainer(tiny("morf"), frames_factory(), texture_init(cfg)).use_averaged_weights() is False
    with pytest.raises(InputError, match="ema_decay"):
        tiny("morf", ema_decay=1.0).validate()


def test_resume_with_weight_average_matches_an_uninterrupted_run(frames_factory, tmp_path):
    frames = frames_factory()
    cfg = tiny("morf", steps=12, checkpoint_minutes=1e6, report_every=1, ema_decay=0.9)
    a, b = _stopped_at_5_and_resumed(frames, cfg, tmp_path)
    assert torch.allclose(a.texture, b.texture, atol=1e-5)
    # the avatar's renderer is the average the checkpoint holds, not the last step's weights
    ckpt = RunDir(tmp_path / "run").load_checkpoint()
    names = [n for n, _ in Trainer(cfg, frames, texture_init(cfg)).model.named_parameters()]
    avg = dict(zip(names, ckpt["ema"]))
    for name, w in a.renderer.state_dict().items():
        assert torch.allclose(w, avg["renderer." + name], atol=1e-6)
        assert not torch.allclose(w, ckpt["model"]["renderer." + name])
    assert "moving average" in (tmp_path / "run" / "train.log").read_text()


def test_nan_raises_and_keeps_last_good_checkpoint(frames_factory, tmp_path, monkeypatch):
    frames = frames_factory()
    cfg = tiny("stylepeople", steps=6, checkpoint_minutes=1e6)
    control = StageControl()
    control._on_progress = lambda p: control.stop() if p.step >= 3 else None
    with pytest.raises(StopRequested):
        train_avatar(frames, tmp_path / "run", cfg.replace(report_every=1), texture_init(cfg), control)
    run = RunDir(tmp_path / "run")
    before = run.load_checkpoint()
    import morf.train.trainer as trainer_mod

    real = trainer_mod.generator_losses

    def poisoned(*a, **k):
        losses = real(*a, **k)
        losses["l1"] = losses["l1"] * float("nan")
        return losses

    monkeypatch.setattr(trainer_mod, "generator_losses", poisoned)
    with pytest.raises(TrainingDiverged, match="kept"):
        train_avatar(frames, run.root, cfg.replace(report_every=1), texture_init(cfg))
    after = run.load_checkpoint()
    assert after["step"] == before["step"] == 3
    assert all(torch.isfinite(v).all() for v in after["model"].values() if v.is_floating_point())
    assert not run.is_done


def test_bf16_channels_last_training_matches_float32(frames_factory):
    """The cpu preset's fast path (bf16 autocast) computes the same losses as float32 within bf16
    precision and keeps training finite. (Channels-last is covered by the renderer's forward test:
    at these tiny sizes oneDNN's channels-last bf16 kernels take seconds per step.)"""
    frames = frames_factory()
    cfg = tiny("morf", steps=3, w_gan=0.02)
    ref = Trainer(cfg, frames, texture_init(cfg))
    fast = Trainer(cfg.replace(bf16=True), frames, texture_init(cfg))
    for _ in range(cfg.steps):
        a, b = ref.train_step()[0], fast.train_step()[0]
        assert np.isfinite(list(b.values())).all()
        assert abs(a["l1"] - b["l1"]) < 0.02 * a["l1"] + 1e-3
    assert fast.parameters_finite()


def test_preview_shows_the_warp_and_its_effect_on_the_texture():
    from types import SimpleNamespace

    from morf.train.loop import _preview

    tex = torch.randn(8, 16, 16)
    batch = SimpleNamespace(image=torch.rand(1, 3, 8, 8), mask=torch.ones(1, 1, 8, 8))
    still = _preview(SimpleNamespace(rgb=torch.rand(1, 3, 8, 8), offsets=torch.zeros(1, 2, 16, 16)), batch, tex)
    left, right = still["warp_effect"][:, :16], still["warp_effect"][:, 16:]
    assert still["warp"].shape == (16, 16, 3) and np.array_equal(left, right)  # zero offsets change nothing
    moved = _preview(SimpleNamespace(rgb=torch.rand(1, 3, 8, 8), offsets=torch.full((1, 2, 16, 16), 0.2)), batch, tex)
    assert not np.array_equal(moved["warp_effect"][:, :16], moved["warp_effect"][:, 16:])
    assert "warp" not in _preview(SimpleNamespace(rgb=torch.rand(1, 3, 8, 8), offsets=None), batch, tex)


def test_zoomed_frames_take_every_other_step(frames_factory):
    """With zoom_resolution the odd steps train on crops of the same frames at the larger side."""
    import dataclasses

    cfg = tiny("stylepeople", resolution=32, zoom_resolution=64, steps=4)
    small = frames_factory(n=4, res=32)
    large = frames_factory(n=4, res=64)
    large = dataclasses.replace(large, images=np.full_like(large.images, 255))  # tells the two sets apart
    tr = Trainer(cfg, small, texture_init(cfg), zoom_frames=large)
    seen = []
    for _ in range(4):
        batch = tr.next_batch()
        seen.append((batch.image.shape[-1], bool((batch.image == 1).all())))
        tr.train_step()
    assert seen == [(32, False), (32, True), (32, False), (32, True)]  # same cost, every other step zoomed
    with pytest.raises(ValueError):
        Trainer(cfg, small, texture_init(cfg), zoom_frames=frames_factory(n=3, res=64))
    with pytest.raises(InputError):
        tiny("stylepeople", resolution=32, zoom_resolution=36).validate()  # not a multiple of 8


def test_bf16_only_where_the_cpu_has_it(frames_factory, monkeypatch):
    """bf16 autocast on the CPU only with native support (AMX-BF16 or AVX512-BF16)."""
    import morf.train.trainer as trainer_mod

    cfg = tiny("stylepeople", bf16=True)
    monkeypatch.setattr(trainer_mod, "bf16_disagreement", lambda modules, device: (0.002, ""))
    for native in (True, False):
        monkeypatch.setattr(trainer_mod, "native_bf16", lambda native=native: native)
        assert Trainer(cfg, frames_factory(), texture_init(cfg), device="cpu").bf16 is native
    assert Trainer(tiny("stylepeople"), frames_factory(), texture_init(cfg), device="cpu").bf16 is False


def test_bf16_off_where_its_convolutions_are_wrong(frames_factory, monkeypatch):
    """A native-bf16 CPU whose bfloat16 convolution disagrees with float32 trains in float32, and
    train.log's line says why; the check sees the trainer's own renderer."""
    import morf.train.trainer as trainer_mod

    cfg = tiny("stylepeople", bf16=True)
    seen = []

    def disagree(modules, device):
        seen.extend(m for m in modules if m is not None)
        return 1.16, "stem.0 (16->16 channels, kernel 4x4, stride 4)"

    monkeypatch.setattr(trainer_mod, "native_bf16", lambda: True)
    monkeypatch.setattr(trainer_mod, "bf16_disagreement", disagree)
    t = Trainer(cfg, frames_factory(), texture_init(cfg), device="cpu")
    assert t.bf16 is False and seen[0] is t.model.renderer
    assert t.bf16_note.startswith("off (this machine's bfloat16 convolution disagrees with float32 at stem.0")


def test_cpu_flags_read_from_cpuinfo(monkeypatch, tmp_path):
    import builtins

    from morf.machine import features as cpu_features

    text = "processor : 0\nflags : fpu avx2 avx512f avx512_vnni\n"
    real_open = builtins.open
    monkeypatch.setattr(builtins, "open", lambda p, *a, **k: real_open(tmp_path / "ci", *a, **k)
                        if p == "/proc/cpuinfo" else real_open(p, *a, **k))
    (tmp_path / "ci").write_text(text)
    cpu_features.cpu_flags.cache_clear()
    try:
        assert not cpu_features.native_bf16()
        assert cpu_features.cpu_summary()["flags"] == ["avx2", "avx512f", "avx512_vnni"]
        (tmp_path / "ci").write_text(text.replace("avx512_vnni", "avx512_vnni amx_bf16"))
        cpu_features.cpu_flags.cache_clear()
        assert cpu_features.native_bf16()
    finally:
        cpu_features.cpu_flags.cache_clear()


def test_warp_fade_scales_the_offsets_to_zero_and_skips_the_bake(frames_factory, tmp_path):
    from morf.train.objective import render_batch

    cfg = tiny("morf", steps=10, w_gan=0.0, warp_fade_start=0.2, warp_fade_end=0.6)
    assert [round(cfg.warp_scale(s), 2) for s in (0, 1, 2, 3, 4, 5, 6, 9)] == [1, 1, 1, 0.75, 0.5, 0.25, 0, 0]
    assert tiny("morf").warp_scale(39) == 1.0 and not tiny("morf").warp_faded and cfg.warp_faded
    with pytest.raises(InputError, match="warp_fade"):
        tiny("morf", warp_fade_start=0.8, warp_fade_end=0.5).validate()
    frames = frames_factory()
    tr = Trainer(cfg, frames, texture_init(cfg))
    for _ in range(3):
        tr.train_step()
    batch = tr.next_batch()
    full, half = (render_batch(tr.model, batch, False, s) for s in (1.0, 0.5))
    assert full.offsets.abs().max() > 0 and torch.allclose(half.offsets, 0.5 * full.offsets)
    tr.step = 7
    losses, out, _ = tr.train_step()
    assert out.offsets is None and "warp_l2" not in losses  # faded out: no warp, no warp terms
    res = train_avatar(frames, tmp_path / "run", cfg, texture_init(cfg))
    assert "texture not baked" in (tmp_path / "run" / "train.log").read_text()
    trained = torch.load(tmp_path / "run" / "checkpoint.pt", weights_only=True)["model"]["texture.texture"]
    assert torch.equal(load_trained_avatar(res.run_dir).texture, trained)  # no inpainting in tiny() here


@pytest.mark.parametrize("change, words", [
    ({"steps": 0}, "steps must be at least 1"), ({"steps": -5}, "steps must be at least 1"),
    ({"lr_texture": -1e-3}, "lr_texture must be >= 0"), ({"lr_renderer": float("nan")}, "lr_renderer must be a finite"),
    ({"batch_size": 0}, "batch size must be at least 1"), ({"resolution": 0}, "resolution must be a positive"),
    ({"resolution": -64}, "resolution must be a positive"), ({"log_every": 0}, "log_every must be at least 1"),
    ({"anr_texture_every": 0}, "anr_texture_every must be at least 1"), ({"w_l1": -1.0}, "w_l1 must be >= 0"),
    ({"steps": 2.5}, "steps must be a whole number"), ({"bf16": 1}, "bf16 must be true or false"),
    ({"checkpoint_minutes": float("inf")}, "checkpoint_minutes must be a finite"), ({"seed": -1}, "seed must be >= 0"),
])
def test_nonsensical_numbers_are_refused_with_one_line(change, words):
    with pytest.raises(InputError, match=words) as e:
        preset("tiny", "morf", **change)
    assert "\n" not in str(e.value)
    d = preset("tiny", "morf").to_dict()
    with pytest.raises(InputError, match=words):  # a config file or a run's config.json read back
        type(preset("tiny")).from_dict({**d, **change})


def test_nonsensical_network_sizes_are_refused():
    cfg = preset("tiny", "morf")
    with pytest.raises(InputError, match="renderer widths"):
        cfg.replace(renderer=dataclasses.replace(cfg.renderer, width=0))
    with pytest.raises(InputError, match="renderer.stem must be a whole number"):
        cfg.with_settings([]).from_dict({**cfg.to_dict(), "renderer": {**cfg.to_dict()["renderer"], "stem": "2"}})
    with pytest.raises(InputError, match="warp sizes"):
        cfg.replace(warp=dataclasses.replace(cfg.warp, latent_dim=0))
    cfg.replace(method="stylepeople", warp=dataclasses.replace(cfg.warp, latent_dim=0))  # no warp: not used


def test_a_run_config_from_before_the_frame_rule_keeps_its_hold_out_rule():
    d = preset("tiny", "morf", holdout=4).to_dict()
    assert d["holdout_by"] == "frame"
    old = {k: v for k, v in d.items() if k != "holdout_by"}  # a whole config.json written before the rule
    assert type(preset("tiny")).from_dict(old).holdout_by == "position"
    assert type(preset("tiny")).from_dict({"holdout": 4}).holdout_by == "frame"  # a partial config file: the rule now
    with pytest.raises(InputError, match="holdout_by"):
        type(preset("tiny")).from_dict({**d, "holdout_by": "random"})


def test_the_rgb_floor_records_zero_steps():
    assert preset("tiny", "rgb", steps=0).steps == 0


def test_train_steps_0_is_one_line_and_creates_no_run(tmp_path, capsys):
    from morf.capture.project import CaptureProject
    from morf.cli.main import main

    project = CaptureProject.create(tmp_path / "cap", num_frames=2, width=64, height=64, fps=None,
                                    source={"kind": "test"})
    assert main(["train", str(project.root), "--preset", "tiny", "--steps", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("morf train: error: steps must be at least 1, got 0")
    assert not (project.runs_dir / "morf-tiny").exists()


def test_resume_with_random_backdrops_matches_an_uninterrupted_run(frames_factory, tmp_path):
    # the backdrop colours come from the step's seed, not from torch's global generator, which a
    # resumed process has not advanced through the steps before its checkpoint
    cfg = tiny("morf", steps=12, checkpoint_minutes=1e6, report_every=1, loss_background="random")
    a, b = _stopped_at_5_and_resumed(frames_factory(), cfg, tmp_path)
    assert torch.equal(a.texture, b.texture)
    for name, w in a.renderer.state_dict().items():
        assert torch.equal(w, b.renderer.state_dict()[name]), name


def test_metrics_of_steps_after_the_checkpoint_are_dropped_on_resume(frames_factory, tmp_path):
    frames = frames_factory()
    cfg = tiny("morf", steps=12, checkpoint_minutes=1e6, report_every=1, log_every=1)
    control = StageControl()
    control._on_progress = lambda p: control.stop() if p.step >= 5 else None
    with pytest.raises(StopRequested):
        train_avatar(frames, tmp_path / "run", cfg, texture_init(cfg), control)
    run = RunDir(tmp_path / "run")
    with open(run.metrics_path, "a") as f:  # what a session killed past its checkpoint left behind
        f.write('{"step": 6, "l1": 0.5}\n{"step": 7, "l1": 0.4}\n{"step": 8, "l1"')
    train_avatar(frames, run.root, cfg, texture_init(cfg))
    assert [m["step"] for m in run.read_metrics()] == list(range(1, 13))
    assert "3 metrics lines of later steps" in run.log_path.read_text()


KILL_AT_SECOND_CHECKPOINT = """
import os, signal, sys
sys.path.insert(0, sys.argv[1])
import torch
from conftest import synthetic_frames
from morf.train.config import preset
from morf.train.loop import train_avatar
from morf.train.run_dir import RunDir

torch.set_num_threads(1)
if sys.argv[3] == "kill":
    real, saves = RunDir.save_checkpoint, [0]
    def save_then_die(self, state):
        real(self, state)
        saves[0] += 1
        if saves[0] == 2:
            with open(self.root / "metrics.jsonl", "a") as f:
                f.write('{"step": 99')  # a line cut by the kill
            os.kill(os.getpid(), signal.SIGKILL)
    RunDir.save_checkpoint = save_then_die
cfg = preset("tiny", "morf", resolution=32, steps=10, batch_size=2, texture_size=32, inpaint_steps=0,
             checkpoint_minutes=0.0, ema_decay=0.9, loss_background="random", device="cpu")
for run in [sys.argv[2], *sys.argv[4:]]:  # "resume RUN STRAIGHT": the killed run, then an uninterrupted one
    g = torch.Generator().manual_seed(0)
    tex = torch.randn(cfg.texture_channels, 32, 32, generator=g) * 0.5
    train_avatar(synthetic_frames(), run, cfg, tex)
"""


def test_kill_9_after_a_checkpoint_then_resume_equals_an_uninterrupted_run(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    from pathlib import Path

    here = str(Path(__file__).parent)

    def train(run, mode, *more):
        return subprocess.run([sys.executable, "-c", KILL_AT_SECOND_CHECKPOINT, here, str(run), mode, *map(str, more)],
                              capture_output=True, timeout=300, env=dict(os.environ, MORF_QUIET="1"))

    killed = train(tmp_path / "run", "kill")
    assert killed.returncode == -signal.SIGKILL, killed.stderr.decode()[-2000:]
    run = RunDir(tmp_path / "run")
    assert run.load_checkpoint()["step"] == 2 and not run.is_done
    # a second process resumes the killed run, then trains the same run uninterrupted in a new
    # folder (one interpreter start less than a third process)
    done = train(tmp_path / "run", "resume", tmp_path / "straight")
    assert done.returncode == 0, done.stderr.decode()[-2000:]
    assert "resumed at step 2" in run.log_path.read_text()
    assert "resumed" not in RunDir(tmp_path / "straight").log_path.read_text()
    a, b = load_trained_avatar(tmp_path / "run"), load_trained_avatar(tmp_path / "straight")
    assert torch.equal(a.texture, b.texture)
    for name, w in a.renderer.state_dict().items():
        assert torch.equal(w, b.renderer.state_dict()[name]), name
    assert [m["step"] for m in run.read_metrics()] == [5, 10]
