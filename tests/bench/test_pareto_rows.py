"""``morf bench pareto``'s rows, seed means, charts' labels and run names: the parts that need
no training (the trainings are in test_pareto.py, which shares them between its tests)."""

import hashlib
import json

import pytest

def test_crowded_chart_labels_move_apart():
    from morf.bench.charts import _label_offsets

    # the second and fourth points sit on top of earlier ones: each moves down one line per neighbour
    off = _label_offsets([20.0, 20.05, 30.0, 20.02], [18.0, 18.01, 17.0, 18.0])
    assert off[0] == off[2] == 3.0 and off[1] == 3.0 - 9.0 and off[3] == 3.0 - 18.0
    assert _label_offsets([], []) == []


def sweep_row(name: str, axis: str, psnr_person: float | None, fps: float | None = 30.0):
    from morf.bench.pareto_results import PointRow
    from morf.bench.train_eval import PlaybackSpeed, RunSpeed, TrainEvaluation

    if psnr_person is None:  # training raised
        return PointRow(name, axis, "morf", "int8", "k", {}, TrainEvaluation(1000, True, error="NaN"), None, 1.0)
    ev = TrainEvaluation(1000, False, 25.0, 0.9, psnr_person, 0.8, 0.01, 1.0, 6, background=(0.5, 0.5, 0.5),
                         frames=3, run=f"/p/runs/{name}", eval_resolution=64)
    return PointRow(name, axis, "morf", "int8", "k", {"resolution": 64}, ev,
                    None if fps is None else RunSpeed(PlaybackSpeed(fps, 1000 / fps, 5.0, 40.0), 38.0), 1.0)


def test_no_seed_spread_without_seed_points():
    from morf.bench.pareto import seed_spread

    rows = [sweep_row("base", "base", 20.0), sweep_row("texture-32", "texture_size", 19.0)]
    assert seed_spread(rows) is None
    rows.append(sweep_row("seed-1", "seed", 21.0))
    rows.append(sweep_row("seed-2", "seed", None))  # diverged: left out
    s = seed_spread(rows)
    assert s["points"] == ["base", "seed-1"] and s["range_db"] == pytest.approx(1.0)


def test_a_point_row_keeps_its_keys_and_order():
    import dataclasses

    from morf.bench.pareto import with_seeds
    from morf.bench.pareto_results import PointRow

    row = sweep_row("base", "base", 20.0)
    saved = row.to_dict()
    assert list(saved) == ["name", "axis", "method", "precision", "key", "config", "psnr", "ssim", "psnr_person",
                           "ssim_person", "temporal", "background", "frames", "diverged", "params", "train_minutes",
                           "steps", "run", "eval_resolution", "fps", "frame_ms", "renderer_ms",
                           "int8_psnr_vs_fp32_db", "int8_psnr_vs_fp32_image_db", "seconds"]
    assert PointRow.from_dict(json.loads(json.dumps(saved))) == row
    fp32 = dataclasses.replace(row, precision="fp32", speed=dataclasses.replace(
        row.speed, playback=dataclasses.replace(row.speed.playback, int8_psnr_vs_fp32_image_db=None)))
    assert "int8_psnr_vs_fp32_image_db" not in fp32.to_dict()
    raised = sweep_row("r", "renderer", None).to_dict()
    assert list(raised)[6:9] == ["diverged", "error", "params"] and raised["fps"] is None and "run" not in raised
    # the sweep adds the seeds and the fronts after the point file's keys
    seeded = dataclasses.replace(with_seeds(row, [sweep_row("base-seed1", "base", 22.0, fps=None)]),
                                 on_front_fps=True, on_front_train=False)
    assert list(seeded.to_dict())[-4:] == ["seed_runs", "seed_means", "on_front_fps", "on_front_train"]
    assert seeded.seed_runs["psnr_person"] == [20.0, 22.0] and seeded.seed_runs["fps"] == [30.0, None]
    assert seeded.mean("psnr_person") == pytest.approx(21.0) and seeded.mean("fps") == 30.0
    assert row.mean("psnr_person") == 20.0


def test_schedule_points_and_run_names_of_constant_rate_configs():
    from morf.presets.sweep import PRESETS
    from morf.sizing.sweep import SweepPoint, resolve, train_key

    sweep = PRESETS["default"]
    base = resolve(sweep, SweepPoint("base", "base"))
    points = {p.name: p for p in sweep.points}
    const = resolve(sweep, points["lr-constant"])
    half = resolve(sweep, points["lr-decay-half"])
    assert const.lr_decay_start == 1.0 and half.lr_decay_start == 0.5
    assert resolve(sweep, points["lr-cosine-all"]).lr_decay_start == 0.0
    assert len({train_key(const), train_key(half)}) == 2
    # the cpu preset decays over the second half: that point is the base, trained once
    assert base.lr_decay_start == 0.5 and train_key(half) == train_key(base)
    # while the decay is off its fields leave the run name alone (runs made before it keep theirs),
    # so the floor, which changes nothing then, does not rename the run either
    plain = const.replace(ema_decay=0.0)
    assert train_key(plain) == train_key(plain.replace(lr_decay_floor=0.5))
    before = {k: v for k, v in plain.to_dict().items() if not k.startswith("lr_decay") and k != "ema_decay"}
    assert train_key(plain) == hashlib.sha1(json.dumps(before, sort_keys=True).encode()).hexdigest()[:10]
    assert train_key(half) != train_key(half.replace(lr_decay_floor=0.5))
    ema, no_ema = resolve(sweep, points["ema"]), resolve(sweep, points["no-ema"])
    assert ema.ema_decay == 0.998 and no_ema.ema_decay == 0.0 and train_key(ema) != train_key(no_ema)


def test_a_renderer_name_gives_its_whole_architecture_and_its_own_run_name(monkeypatch):
    from morf.sizing import sweep
    from morf.presets.sweep import PRESETS
    from morf.sizing.sweep import SweepPoint, resolve, train_key

    cfg = resolve(PRESETS["default"], SweepPoint("r", "renderer", {"renderer": "stem2_b16"}))
    half = resolve(PRESETS["default"], SweepPoint("r", "renderer", {"renderer": "stem4_b16"}))
    assert cfg.renderer.head_stride == 1 and half.renderer.head_stride == 2  # not the preset's head
    assert train_key(half) != train_key(cfg)
    # a full-resolution head leaves the name alone: runs made before the field keep theirs
    hashed = []
    monkeypatch.setattr(sweep.json, "dumps", lambda d, **kw: hashed.append(d) or "{}")
    train_key(cfg)
    train_key(half)
    assert "head_stride" not in hashed[0]["renderer"] and hashed[1]["renderer"]["head_stride"] == 2
