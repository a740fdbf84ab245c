"""``morf bench stability`` on the tiny preset (two series, two methods) and the breakdown rule."""

import json

import pytest

from morf.bench.stability import BREAKDOWN_DB, breaks_down_at, run_stability
from morf.bench.stability_rows import StabilityPoint
from morf.bench.train_eval import TrainEvaluation
from morf.scale.ray_runtime import RayOptions

HERE = RayOptions(in_process=True)  # trainings in this process: the series are checked here, Ray in tests/test_scale_ray.py


def point(psnr_person, seed=0, diverged=False, **scores) -> StabilityPoint:
    if diverged and psnr_person is None:  # training raised
        return StabilityPoint("slide", 0, "morf", seed, TrainEvaluation(1000, True, error="loss went NaN"))
    ev = TrainEvaluation(1000, diverged, psnr_person=psnr_person, background=(0.5, 0.5, 0.5), frames=3,
                         run=f"r{seed}", eval_resolution=64, **scores)
    return StabilityPoint("slide", 0, "morf", seed, ev)


def test_breakdown_rule():
    levels = [0, 1, 2, 3]
    rows = [point(20.0), point(19.5), point(20 - BREAKDOWN_DB - 0.1), point(10.0)]
    assert breaks_down_at(levels, rows) == 2
    assert breaks_down_at(levels, rows[:2]) is None
    assert breaks_down_at(levels, [rows[0], point(None, diverged=True)]) == 1


@pytest.fixture(scope="module")
def stab_dir(tmp_path_factory):
    """OUT of both tiny runs here: the second reuses the first's clean capture and its training."""
    return tmp_path_factory.mktemp("stability") / "stab"


@pytest.mark.gl
def test_tiny_stability_series(stab_dir, body_model, gl):
    out = stab_dir
    run_stability(out, "tiny", series=["misalignment", "coverage"], methods=["morf", "stylepeople"],
                  model=body_model, ray=HERE)
    data = json.loads((out / "stability.json").read_text())
    assert {"series", "methods", "breakdown_rule", "charts", "machine"} <= set(data)
    for name in ("misalignment", "coverage"):
        s = data["series"][name]
        assert {"label", "levels", "methods", "breaks_down_at"} <= set(s)
        for m in ("morf", "stylepeople"):
            rows = s["methods"][m]
            assert len(rows) == len(s["levels"])
            for r in rows:
                assert {"psnr", "ssim", "psnr_person", "temporal", "diverged"} <= set(r)
    # level 0 of every synthetic-nuisance series is the same clean training
    assert data["series"]["misalignment"]["methods"]["morf"][0]["run"] == \
        data["series"]["coverage"]["methods"]["morf"][0]["run"]
    # the coverage level hid the back: fewer training frames were used than at level 0
    assert json.loads((out / "captures" / "clean" / "review.json").read_text())["drop"] == []
    for png in ("stability_psnr.png", "stability_temporal.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "points").iterdir()}
    run_stability(out, "tiny", series=["misalignment", "coverage"], methods=["morf", "stylepeople"], model=body_model,
                  ray=HERE)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "points").iterdir()} == stamps


def test_repeats_are_combined_and_their_spread_widens_the_breakdown_threshold():
    import dataclasses

    from morf.bench.stability import breakdown_threshold, combine_repeats

    scores = dict(ssim=0.9, ssim_person=0.8, temporal=0.05, train_minutes=1)
    runs = [point(p, s, psnr=p + 5, **scores) for s, p in enumerate([18.0, 20.0, 22.0])]
    row = combine_repeats(runs)
    assert row.psnr_person == pytest.approx(20.0) and row.psnr == pytest.approx(25.0)
    assert (row.psnr_person_min, row.psnr_person_max) == (18.0, 22.0)
    assert row.psnr_person_std == pytest.approx(2.0) and row.repeats == 3 and not row.diverged
    saved = row.to_dict()
    assert saved["runs"] == ["r0", "r1", "r2"] and "run" not in saved and "steps" not in saved
    assert list(saved) == ["series", "level", "method", "seed", "background", "frames", "diverged", "params",
                           "eval_resolution", "psnr", "ssim", "psnr_person", "ssim_person", "temporal",
                           "train_minutes", "repeats", "diverged_runs", "psnr_person_min", "psnr_person_max",
                           "psnr_person_std", "runs"]
    failed = combine_repeats(runs[:2] + [point(None, 2, diverged=True)])
    assert failed.diverged and failed.diverged_runs == 1 and failed.psnr_person == pytest.approx(19.0)
    assert failed.runs == ("r0", "r1", None)
    first_raised = combine_repeats([point(None, 0, diverged=True)] + runs[1:]).to_dict()
    assert "background" not in first_raised and "eval_resolution" not in first_raised and first_raised["diverged"]
    # a spread of 2 dB: a 3 dB drop is within the noise, a 5 dB drop is not
    assert breakdown_threshold([row]) == pytest.approx(4.0)
    levels = [0, 1]
    lower = lambda p: dataclasses.replace(row, psnr_person=p)  # noqa: E731
    assert breaks_down_at(levels, [row, lower(17.0)], breakdown_threshold([row])) is None
    assert breaks_down_at(levels, [row, lower(15.0)], breakdown_threshold([row])) == 1
    assert breakdown_threshold([dataclasses.replace(row, psnr_person_std=None)]) == BREAKDOWN_DB
    assert breakdown_threshold(runs) == BREAKDOWN_DB  # single trainings: no spread measured


def test_keypoint_captures_are_fitted_with_the_stability_presets_fit_preset(tmp_path, monkeypatch):
    from types import SimpleNamespace

    import morf.fitting.project_fit as project_fit
    from morf import presets
    from morf.bench.stability import _fit

    used = []
    monkeypatch.setattr(project_fit, "fit_project", lambda project, cfg, model=None: used.append(cfg))
    project = SimpleNamespace(fits_path=tmp_path / "fits.npz", fits_dir=tmp_path)
    for name, sp in presets.presets_of("stability").items():
        _fit(project, sp, model=None)
        assert used[-1] == presets.preset("fit", sp.fit).replace(overlays=False), name
    assert presets.preset("stability", "default").fit == "fast"
    assert presets.preset("stability", "tiny").fit == "tiny"


def test_a_point_file_is_read_and_written_back_as_it_was():
    saved = point(18.0, 1, psnr=23.0).to_dict()
    assert list(saved)[:4] == ["series", "level", "method", "seed"]
    assert StabilityPoint.from_dict(json.loads(json.dumps(saved))).to_dict() == saved


@pytest.mark.gl
def test_tiny_stability_with_repeats(stab_dir, body_model, gl):
    out = stab_dir  # level 0 is the clean capture's training of the series above (seed 0), reused
    run_stability(out, "tiny", series=["slide"], methods=["morf"], model=body_model, repeats=2, ray=HERE)
    data = json.loads((out / "stability.json").read_text())
    assert data["repeats"] == 2 and "seeds" in data["breakdown_rule"]
    assert sorted(p.name for p in (out / "points").iterdir() if p.name.startswith("slide-")) == [
        "slide-0-morf-seed1.json", "slide-0-morf.json", "slide-1-morf-seed1.json", "slide-1-morf.json"]
    seeds = [json.loads((out / "points" / f"slide-0-morf{t}.json").read_text())["seed"] for t in ("", "-seed1")]
    assert seeds == [0, 1]
    rows = data["series"]["slide"]["methods"]["morf"]
    assert all(r["repeats"] == 2 and len(set(r["runs"])) == 2 for r in rows)
    assert data["series"]["slide"]["threshold_db"]["morf"] >= BREAKDOWN_DB
    assert "psnr_person_std" in (out / "stability.md").read_text()
