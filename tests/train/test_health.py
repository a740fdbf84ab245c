"""Collapse detection and the roll-back that answers it."""

import pytest
import torch

from morf.errors import TrainingDiverged
from morf.train.config import preset
from morf.train.health import CollapseMonitor
from morf.train.loop import train_avatar
from morf.train.run_dir import RunDir


def _cfg(**kw):
    # default: a checkpoint after every step; the adversarial terms on (their rollback is tested here)
    kw = {"steps": 8, "checkpoint_minutes": 0.0, "w_gan": 0.02, **kw}
    return preset("tiny", "stylepeople", resolution=32, batch_size=2, texture_size=32, inpaint_steps=0,
                  device="cpu", **kw)


def _texture(cfg):
    return torch.zeros(cfg.texture_channels, cfg.texture_size, cfg.texture_size)


def _feed(monitor, values):
    return [monitor.update({"dice": v}) for v in values]


def test_monitor_reports_a_learned_mask_that_dies():
    m = CollapseMonitor()
    assert not any(_feed(m, [0.9] * 20 + [0.5] * 20 + [0.05] * 50))  # learning: never a collapse
    assert m.healthy
    out = _feed(m, [0.03, 0.4, 0.9, 1.0] + [1.0] * 30)
    assert not m.healthy
    assert any(out) and "collapsed" in [r for r in out if r][0]


def test_monitor_is_quiet_before_the_mask_is_learned_and_on_noise():
    m = CollapseMonitor()
    assert not any(_feed(m, [1.0] * 50 + [0.95, 0.99] * 20))  # never learned: nothing to lose
    m = CollapseMonitor()
    assert not any(_feed(m, [0.01, 0.03, 0.008, 0.05, 0.02] * 40))  # noisy but learned
    assert m.healthy
    assert CollapseMonitor().update({"l1": 0.1}) is None  # no mask loss (no Dice): nothing to judge


def test_monitor_reports_a_mask_that_never_formed():
    m = CollapseMonitor()
    out = _feed(m, [0.9] * 10 + [1.0] * 300)  # the discriminator won before the mask was learned
    first = next(i for i, r in enumerate(out) if r)
    assert first >= m.grace - 1 and "never formed" in out[first]
    assert not m.healthy  # a state without a mask is no rollback target
    m = CollapseMonitor()
    assert not any(_feed(m, [0.9] * 150 + [0.6] * 300))  # slow but forming: not flagged
    m = CollapseMonitor()
    assert not any(_feed(m, [1.0] * 150))  # within the grace period (short runs, the tiny preset)


def _collapse_at(monkeypatch, steps):
    """Make the monitor report a collapse on the given step numbers (as counted by update calls)."""
    calls = {"n": 0}
    real = CollapseMonitor.update

    def update(self, losses):
        calls["n"] += 1
        real(self, losses)
        return "the mask collapsed (test)" if calls["n"] in steps else None

    monkeypatch.setattr(CollapseMonitor, "update", update)
    return calls


def test_collapse_rolls_back_to_the_checkpoint_and_finishes(frames_factory, tmp_path, monkeypatch):
    frames = frames_factory()
    cfg = _cfg()
    _collapse_at(monkeypatch, {5})
    res = train_avatar(frames, tmp_path / "run", cfg, _texture(cfg))
    run = RunDir(res.run_dir)
    log = (run.root / "train.log").read_text()
    assert "diverged" in log and "rolled back to the checkpoint of step 4" in log
    assert res.step == 8 and run.is_done
    ckpt = run.load_checkpoint()
    lrs = [g["lr"] for g in ckpt["opt"]["param_groups"]]
    assert lrs and all(abs(lr - 0.5 * base) < 1e-12 for lr, base in zip(lrs, [cfg.lr_texture, cfg.lr_renderer]))


def test_repeated_collapse_stops_with_the_checkpoint_kept(frames_factory, tmp_path, monkeypatch):
    frames = frames_factory()
    cfg = _cfg(max_recoveries=1)
    _collapse_at(monkeypatch, {5, 6})
    with pytest.raises(TrainingDiverged, match="kept"):
        train_avatar(frames, tmp_path / "run", cfg, _texture(cfg))
    run = RunDir(tmp_path / "run")
    assert run.load_checkpoint()["step"] == 4 and not run.is_done
    assert all(torch.isfinite(v).all() for v in run.load_checkpoint()["model"].values() if v.is_floating_point())


def test_collapse_before_any_checkpoint_rolls_back_to_a_snapshot(frames_factory, tmp_path, monkeypatch):
    """Short runs write no checkpoint before the end: a collapse rolls back to the older of the
    two latest in-memory snapshots, and a second one halves the rates again."""
    import morf.train.loop as loop

    monkeypatch.setattr(loop, "SNAPSHOT_EVERY", 2)
    frames = frames_factory()
    cfg = _cfg(checkpoint_minutes=1e6, steps=12)
    _collapse_at(monkeypatch, {7, 12})  # update calls: 1-6 = steps 1-6, 7 collapses; after it call n = step + 1
    res = train_avatar(frames, tmp_path / "run", cfg, _texture(cfg))
    log = (RunDir(res.run_dir).root / "train.log").read_text()
    assert "rolled back to the in-memory state of step 4" in log  # snapshots 4 and 6 were held
    assert "recovery 2 of 2" in log and res.step == 12
    lrs = [g["lr"] for g in RunDir(res.run_dir).load_checkpoint()["opt"]["param_groups"]]
    assert all(abs(lr - 0.25 * base) < 1e-12 for lr, base in zip(lrs, [cfg.lr_texture, cfg.lr_renderer]))


def test_collapse_before_the_first_snapshot_starts_again_from_step_0(frames_factory, tmp_path, monkeypatch):
    """A wide renderer can collapse within the first hundred steps, before any snapshot or
    checkpoint: the run goes back to its initial state with halved learning rates."""
    cfg = _cfg(checkpoint_minutes=1e6, steps=8)
    _collapse_at(monkeypatch, {3})
    res = train_avatar(frames_factory(), tmp_path / "run", cfg, _texture(cfg))
    log = (RunDir(res.run_dir).root / "train.log").read_text()
    assert "rolled back to the in-memory state of step 0" in log and "recovery 1 of" in log
    assert res.step == 8 and RunDir(res.run_dir).is_done
    lrs = [g["lr"] for g in RunDir(res.run_dir).load_checkpoint()["opt"]["param_groups"]]
    assert all(abs(lr - 0.5 * base) < 1e-12 for lr, base in zip(lrs, [cfg.lr_texture, cfg.lr_renderer]))


def test_a_mask_that_never_formed_restarts_with_the_adversarial_terms_held(frames_factory, tmp_path, monkeypatch):
    """The first attempt's mask never forms (Dice 1 while the adversarial terms are on): the run
    restarts from step 0 without them, switches them on once the mask formed, and finishes."""
    import json

    from morf.train.trainer import Trainer

    monkeypatch.setattr(CollapseMonitor, "__init__", _short_grace(CollapseMonitor.__init__))
    real = Trainer.train_step
    held = []

    def train_step(self):
        hold = self.hold_adversarial
        values, out, batch = real(self)
        held.append(hold)
        if not hold and not any(held):  # the first attempt: the discriminator killed the mask
            values["dice"] = 1.0
        elif hold:
            assert "gan" not in values and "disc" not in values
            values["dice"] = 0.0  # forms at once
        return values, out, batch

    monkeypatch.setattr(Trainer, "train_step", train_step)
    cfg = _cfg(checkpoint_minutes=1e6, steps=10, log_every=1)
    res = train_avatar(frames_factory(), tmp_path / "run", cfg, _texture(cfg))
    run = RunDir(res.run_dir)
    log = (run.root / "train.log").read_text()
    assert "never formed" in log and "restarted from step 0" in log and "the mask formed at step 1" in log
    assert res.step == 10 and run.is_done
    assert held == [False] * 4 + [True] + [False] * 9  # 4 failed steps, 1 held, 9 with the GAN
    assert not run.load_checkpoint()["hold_adversarial"]
    rows = [json.loads(line) for line in (run.root / "metrics.jsonl").read_text().splitlines()]
    assert "gan" in rows[-1]
    lrs = [g["lr"] for g in run.load_checkpoint()["opt"]["param_groups"]]  # a restart, not a rollback
    assert all(abs(lr - base) < 1e-12 for lr, base in zip(lrs, [cfg.lr_texture, cfg.lr_renderer]))


def test_a_mask_that_does_not_form_after_the_restart_stops_the_run(frames_factory, tmp_path, monkeypatch):
    from morf.train.trainer import Trainer

    monkeypatch.setattr(CollapseMonitor, "__init__", _short_grace(CollapseMonitor.__init__))
    real = Trainer.train_step

    def train_step(self):
        values, out, batch = real(self)
        values["dice"] = 1.0
        return values, out, batch

    monkeypatch.setattr(Trainer, "train_step", train_step)
    cfg = _cfg(checkpoint_minutes=1e6, steps=30)
    with pytest.raises(TrainingDiverged, match="never formed"):
        train_avatar(frames_factory(), tmp_path / "run", cfg, _texture(cfg))
    log = (tmp_path / "run" / "train.log").read_text()
    assert log.count("restarted from step 0") == 1


def _short_grace(init):
    def short(self, *a, **k):
        init(self, *a, **k)
        self.grace = 4

    return short
