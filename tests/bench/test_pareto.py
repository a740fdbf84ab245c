"""``morf bench pareto`` on the tiny preset: documented JSON keys, charts, and resumability."""

import hashlib
import json
import shutil

import pytest

from morf.bench.pareto import run_sweep

POINT_KEYS = {"name", "axis", "method", "precision", "config", "params", "psnr", "ssim", "psnr_person",
              "ssim_person", "temporal", "train_minutes", "fps", "frame_ms", "renderer_ms", "int8_psnr_vs_fp32_db",
              "diverged", "on_front_fps", "on_front_train"}


AXES = ["texture_size", "precision"]


@pytest.fixture(scope="module")
def tiny_sweep(sweep_dir, print_capture, body_model):
    """(OUT, result, pareto.json as written) of the tiny sweep's texture and precision points, in
    the shared folder whose capture the other sweep tests measure their points on."""
    out = sweep_dir / "pareto"
    res = run_sweep(out, "tiny", axes=AXES, model=body_model)
    return out, res, json.loads((out / "pareto.json").read_text())


@pytest.mark.gl
def test_tiny_sweep_writes_results_and_resumes(tiny_sweep, print_capture, body_model, tmp_path):
    out, res, data = tiny_sweep
    assert {"points", "front_fps", "front_train", "quality_metric", "fps_size", "paper_reference", "charts",
            "machine"} <= set(data)
    assert data["project"] == str(print_capture.root)  # the capture the sweep made in OUT
    names = [p["name"] for p in data["points"]]
    assert names == ["base", "texture-32", "fp32"]
    for p in data["points"]:
        assert POINT_KEYS <= set(p), POINT_KEYS - set(p)
        assert not p["diverged"] and p["fps"] > 0 and p["train_minutes"] > 0
    assert data["front_fps"] and data["front_train"]
    # int8 and fp32 of one model share the training run: same quality, separate speeds
    base, fp32 = data["points"][0], data["points"][2]
    assert base["run"] == fp32["run"] and base["psnr_person"] == fp32["psnr_person"]
    assert data["paper_reference"]["comparable"] == ["fps"]
    floor = data["floor"]  # the RGB floor: a quality with no speed, a line on the charts
    assert floor["fps"] is None and floor["psnr_person"] is not None and floor["run"].endswith("pareto-rgb-64")
    assert list(floor) == ["name", "run", "fps", "psnr_person", "ssim_person", "psnr", "temporal"]
    assert res.floor.run == floor["run"] and res.floor.metric("psnr_person") == floor["psnr_person"]
    assert "RGB floor" in (out / "pareto.md").read_text()
    for png in ("pareto_fps.png", "pareto_train.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert res.reused == ()
    assert res.to_dict() == data

    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "points").iterdir()}
    again = run_sweep(out, "tiny", axes=AXES, model=body_model)
    assert list(again.reused) == names
    assert {p.name: p.stat().st_mtime_ns for p in (out / "points").iterdir()} == stamps

    # naming one point keeps the others measured on this capture, and only those (in a copy of
    # OUT's results: the shared folder keeps its points for the other tests)
    grown = run_sweep(out, "tiny", axes=AXES, points=["fp32"], model=body_model)
    assert [p.name for p in grown.points] == names and list(grown.reused) == names
    copy = tmp_path / "pareto"
    shutil.copytree(out / "points", copy / "points")
    moved = json.loads((copy / "points" / "texture-32.json").read_text())
    moved["run"] = str(tmp_path / "another-capture" / "runs" / "x")
    (copy / "points" / "texture-32.json").write_text(json.dumps(moved))
    alone = run_sweep(copy, "tiny", project_path=str(print_capture.root), axes=AXES, points=["fp32"],
                      model=body_model)
    assert [p.name for p in alone.points] == ["base", "fp32"] and list(alone.reused) == ["base", "fp32"]


@pytest.mark.gl
def test_a_resolution_point_is_scored_at_the_base_resolution(tiny_sweep, body_model):
    from morf.bench.train_eval import holdout_quality
    from morf.capture.project import CaptureProject
    from morf.presets.sweep import PRESETS
    from morf.sizing.sweep import SweepPoint, resolve

    sweep = PRESETS["tiny"]
    point = SweepPoint("resolution-32", "resolution", {"resolution": 32})
    out = tiny_sweep[0]
    data = run_sweep(out, "tiny", axes=["resolution"], model=body_model, extra=[(point, resolve(sweep, point))])
    rows = {p.name: p for p in data.points}
    assert list(rows) == ["base", "resolution-32"]
    base_res = resolve(sweep, SweepPoint("base", "base")).resolution
    assert rows["resolution-32"].config["resolution"] == 32 != base_res
    assert rows["resolution-32"].evaluation.eval_resolution == rows["base"].evaluation.eval_resolution == base_res
    project = CaptureProject.open(data.project)
    at_base = holdout_quality(project, rows["resolution-32"].evaluation.run, body_model, base_res)
    at_own = holdout_quality(project, rows["resolution-32"].evaluation.run, body_model)
    assert at_base.psnr == pytest.approx(rows["resolution-32"].evaluation.psnr)
    assert at_base.psnr != pytest.approx(at_own.psnr)


def test_crowded_chart_labels_move_apart():
    from morf.bench.charts import _label_offsets

    # the second and fourth points sit on top of earlier ones: each moves down one line per neighbour
    off = _label_offsets([20.0, 20.05, 30.0, 20.02], [18.0, 18.01, 17.0, 18.0])
    assert off[0] == off[2] == 3.0 and off[1] == 3.0 - 9.0 and off[3] == 3.0 - 18.0
    assert _label_offsets([], []) == []


@pytest.mark.gl
def test_seed_points_measure_the_noise_and_stay_off_the_fronts(tiny_sweep, body_model):
    out = tiny_sweep[0]
    data = run_sweep(out, "tiny", axes=["seed"], model=body_model).to_dict()
    rows = {p["name"]: p for p in data["points"]}
    assert list(rows) == ["base", "seed-1"]
    assert rows["seed-1"]["run"] != rows["base"]["run"]
    assert not rows["seed-1"]["on_front_fps"] and not rows["seed-1"]["on_front_train"]
    assert "seed-1" not in data["front_fps"] + data["front_train"] and data["front_fps"] == ["base"]
    spread = data["seed_spread"]
    q = [rows["base"]["psnr_person"], rows["seed-1"]["psnr_person"]]
    assert spread["points"] == ["base", "seed-1"] and spread["psnr_person"] == q
    assert spread["range_db"] == pytest.approx(abs(q[0] - q[1])) and spread["range_db"] > 0
    assert "seeds spans" in (out / "pareto.md").read_text()


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


@pytest.mark.gl
def test_sweep_with_seeds_charts_the_means(tiny_sweep, body_model):
    out = tiny_sweep[0]
    res = run_sweep(out, "tiny", axes=["texture_size"], model=body_model, seeds=2).to_dict()
    assert res["seeds"] == 2 and [p["name"] for p in res["points"]] == ["base", "texture-32"]
    saved = {p.stem for p in (out / "points").glob("*.json")}
    assert {"base", "texture-32", "base-seed1", "texture-32-seed1"} <= saved
    assert not {n for n in saved if n.endswith("-seed2")}  # two seeds: one repeat a point
    again = json.loads((out / "points" / "base-seed1.json").read_text())
    assert again["run"] != res["points"][0]["run"]  # a second training, not the first one read again
    for p in res["points"]:
        runs = p["seed_runs"]["psnr_person"]
        assert len(runs) == 2 and runs[0] == p["psnr_person"]
        assert p["seed_means"]["psnr_person"] == pytest.approx(sum(runs) / 2)
    md = (out / "pareto.md").read_text()
    assert "means over 2 seeds" in md and "psnr_person runs" in md


def test_bad_seed_count_is_one_line_error(tmp_path, capsys):
    from morf.cli.main import main

    rc = main(["bench", "pareto", "--out", str(tmp_path / "p"), "--preset", "tiny", "--seeds", "0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "seeds must be at least 1" in err[0]
    assert not (tmp_path / "p").exists()


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
