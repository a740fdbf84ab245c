"""``morf bench pareto`` on the tiny preset: documented JSON keys, charts, and resumability."""

import json
import shutil

import pytest

from morf.bench.auto_check import auto_check
from morf.bench.pareto import run_sweep
from morf.scale.ray_runtime import RayOptions

POINT_KEYS = {"name", "axis", "method", "precision", "config", "params", "psnr", "ssim", "psnr_person",
              "ssim_person", "temporal", "train_minutes", "fps", "frame_ms", "renderer_ms", "int8_psnr_vs_fp32_db",
              "diverged", "on_front_fps", "on_front_train"}


AXES = ["texture_size", "precision"]
# The trainings run in this process (``--address here``): what these tests check is the sweep, and
# a Ray worker per test file would import torch and morf again (Ray itself: tests/test_scale_ray.py).
HERE = RayOptions(in_process=True)


@pytest.fixture(scope="module")
def tiny_sweep(sweep_dir, print_capture, body_model):
    """(OUT, result, pareto.json as written) of the tiny sweep's texture and precision points, in
    the shared folder whose capture the other sweep tests measure their points on."""
    out = sweep_dir / "pareto"
    res = run_sweep(out, "tiny", axes=AXES, model=body_model, ray=HERE)
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
    again = run_sweep(out, "tiny", axes=AXES, model=body_model, ray=HERE)
    assert list(again.reused) == names
    assert {p.name: p.stat().st_mtime_ns for p in (out / "points").iterdir()} == stamps

    # naming one point keeps the others measured on this capture, and only those (in a copy of
    # OUT's results: the shared folder keeps its points for the other tests)
    grown = run_sweep(out, "tiny", axes=AXES, points=["fp32"], model=body_model, ray=HERE)
    assert [p.name for p in grown.points] == names and list(grown.reused) == names
    copy = tmp_path / "pareto"
    shutil.copytree(out / "points", copy / "points")
    moved = json.loads((copy / "points" / "texture-32.json").read_text())
    moved["run"] = str(tmp_path / "another-capture" / "runs" / "x")
    (copy / "points" / "texture-32.json").write_text(json.dumps(moved))
    alone = run_sweep(copy, "tiny", project_path=str(print_capture.root), axes=AXES, points=["fp32"],
                      model=body_model, ray=HERE)
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
    data = run_sweep(out, "tiny", axes=["resolution"], model=body_model, ray=HERE,
                     extra=[(point, resolve(sweep, point))])
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


@pytest.mark.gl
def test_seed_points_measure_the_noise_and_stay_off_the_fronts(tiny_sweep, body_model):
    out = tiny_sweep[0]
    data = run_sweep(out, "tiny", axes=["seed"], model=body_model, ray=HERE).to_dict()
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


@pytest.mark.gl
def test_sweep_with_seeds_charts_the_means(tiny_sweep, body_model):
    out = tiny_sweep[0]
    res = run_sweep(out, "tiny", axes=["texture_size"], model=body_model, seeds=2, ray=HERE).to_dict()
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


# ``--auto-check`` on the same capture: the automatic choice measured beside the sizing points, per
# scene, and the single-scene form on an existing capture. Its base and texture-32 points (and
# their seed repeats) are the trainings above, each trained and timed once (the run's stored speed).

@pytest.mark.gl
def test_tiny_auto_check(sweep_dir, print_capture, body_model, gl):
    out = sweep_dir / "auto"
    # both scenes on the tiny sweep's shared capture (each distinct training runs once; making a
    # capture is the conftest's, through the same make_capture), one sizing point beside the base
    # and the choice: what is checked here is the per-scene loop, its sweeps, verdicts and report
    cap = str(print_capture.root)
    res = auto_check(out, "tiny", body_model, scenes=("plain", "print"), project_path={"plain": cap, "print": cap},
                     points=["texture-32"], ray=HERE)
    data = json.loads((out / "auto_check.json").read_text())
    assert [r["scene"] for r in data["table"]] == ["plain", "print"] == [r["scene"] for r in res["table"]]
    for row in data["table"]:
        assert isinstance(row["near_front"], bool) and row["psnr_person"] is not None and row["fps"] > 0
        assert row["best_psnr_person"] >= row["psnr_person"]
        assert row["gap_se_db"] is None and row["beyond_noise"] is None  # one training per point: no noise estimate
    for scene in ("plain", "print"):
        names = [p["name"] for p in json.loads((out / scene / "pareto.json").read_text())["points"]]
        assert names == ["base", "texture-32", "auto"]  # the points named, then the choice
        assert data["scenes"][scene]["reasons"]
    assert not list(out.glob("*/capture-*"))  # the captures named were used, none made
    assert data["scenes"]["plain"]["point"]["run"] == data["scenes"]["print"]["point"]["run"]
    assert "## plain" in (out / "auto_check.md").read_text()

    # one scene on an existing capture (the path form): the same auto choice, its results reused
    again = auto_check(out, "tiny", body_model, scenes=("print",), project_path=str(print_capture.root),
                       points=["texture-32"], ray=HERE)
    sweep = json.loads((out / "print" / "pareto.json").read_text())
    assert [p["name"] for p in sweep["points"]] == ["base", "texture-32", "auto"]
    assert sweep["reused"] == ["base", "texture-32", "auto"]
    assert again["table"][0]["texture_size"] == data["table"][1]["texture_size"]
    assert again["scenes"]["print"]["point"]["run"] == data["scenes"]["print"]["point"]["run"]


@pytest.mark.gl
def test_auto_check_with_seeds_judges_means(sweep_dir, print_capture, body_model, gl):
    # the folder of the check above: its base, texture-32 and auto points are reused, the seed
    # repeats measured beside them
    out = sweep_dir / "auto"
    res = auto_check(out, "tiny", body_model, scenes=("print",), project_path=str(print_capture.root),
                     points=["texture-32"], seeds=2, ray=HERE)
    means = res["scenes"]["print"]["means"]
    assert list(means) == ["base", "texture-32", "auto"]
    saved = {p.stem for p in (out / "print" / "points").glob("*.json")}
    assert {"base-seed1", "texture-32-seed1", "auto-seed1"} <= saved
    runs = {n: json.loads((out / "print" / "points" / f"{n}.json").read_text())["run"] for n in ("base", "base-seed1")}
    assert runs["base"] != runs["base-seed1"]  # a second training, not the first one read again
    for m in means.values():
        assert len(m["psnr_person_runs"]) == 2
        assert m["psnr_person"] == pytest.approx(sum(m["psnr_person_runs"]) / 2)
    row = res["table"][0]
    assert row["psnr_person"] == means["auto"]["psnr_person"]
    assert row["best_psnr_person"] == max(m["psnr_person"] for m in means.values())
    rival = res["scenes"]["print"]["rival"]  # None only when every other point timed 20 % slower
    if rival is None:
        assert row["gap_db"] is None and row["beyond_noise"] is None
    else:
        assert row["gap_db"] == pytest.approx(means[rival]["psnr_person"] - row["psnr_person"])
        assert row["gap_se_db"] >= 0 and isinstance(row["beyond_noise"], bool)
    assert json.loads((out / "auto_check.json").read_text())["seeds"] == 2
    assert "means over 2 seeds" in (out / "auto_check.md").read_text()
