"""``morf bench stability`` on the tiny preset (two series, two methods) and the breakdown rule."""

import json

import pytest

from morf.bench.stability import BREAKDOWN_DB, breaks_down_at, run_stability


def test_breakdown_rule():
    levels = [0, 1, 2, 3]
    rows = [{"psnr_person": 20.0}, {"psnr_person": 19.5}, {"psnr_person": 20 - BREAKDOWN_DB - 0.1},
            {"psnr_person": 10.0}]
    assert breaks_down_at(levels, rows) == 2
    assert breaks_down_at(levels, rows[:2]) is None
    assert breaks_down_at(levels, [rows[0], {"diverged": True, "psnr_person": None}]) == 1


@pytest.mark.gl
def test_tiny_stability_series(tmp_path, body_model, gl):
    out = tmp_path / "stab"
    run_stability(out, "tiny", series=["misalignment", "coverage"], methods=["morf", "stylepeople"],
                  model=body_model)
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
    run_stability(out, "tiny", series=["misalignment", "coverage"], methods=["morf", "stylepeople"], model=body_model)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "points").iterdir()} == stamps


def test_repeats_are_combined_and_their_spread_widens_the_breakdown_threshold():
    from morf.bench.stability import breakdown_threshold, combine_repeats

    runs = [{"series": "slide", "level": 0, "method": "morf", "seed": s, "run": f"r{s}", "diverged": False,
             "psnr": p + 5, "ssim": 0.9, "psnr_person": p, "ssim_person": 0.8, "temporal": 0.05, "train_minutes": 1}
            for s, p in enumerate([18.0, 20.0, 22.0])]
    row = combine_repeats(runs)
    assert row["psnr_person"] == pytest.approx(20.0) and row["psnr"] == pytest.approx(25.0)
    assert (row["psnr_person_min"], row["psnr_person_max"]) == (18.0, 22.0)
    assert row["psnr_person_std"] == pytest.approx(2.0) and row["repeats"] == 3 and not row["diverged"]
    assert row["runs"] == ["r0", "r1", "r2"] and "run" not in row
    failed = combine_repeats(runs[:2] + [{**runs[2], "diverged": True, "psnr_person": None}])
    assert failed["diverged"] and failed["diverged_runs"] == 1 and failed["psnr_person"] == pytest.approx(19.0)
    # a spread of 2 dB: a 3 dB drop is within the noise, a 5 dB drop is not
    assert breakdown_threshold([row]) == pytest.approx(4.0)
    levels = [0, 1]
    assert breaks_down_at(levels, [row, {**row, "psnr_person": 17.0}], breakdown_threshold([row])) is None
    assert breaks_down_at(levels, [row, {**row, "psnr_person": 15.0}], breakdown_threshold([row])) == 1
    assert breakdown_threshold([{"psnr_person_std": None}]) == BREAKDOWN_DB


@pytest.mark.gl
def test_tiny_stability_with_repeats(tmp_path, body_model, gl):
    out = tmp_path / "stab"
    run_stability(out, "tiny", series=["slide"], methods=["morf"], model=body_model, repeats=2)
    data = json.loads((out / "stability.json").read_text())
    assert data["repeats"] == 2 and "seeds" in data["breakdown_rule"]
    assert sorted(p.name for p in (out / "points").iterdir()) == [
        "slide-0-morf-seed1.json", "slide-0-morf.json", "slide-1-morf-seed1.json", "slide-1-morf.json"]
    seeds = [json.loads((out / "points" / f"slide-0-morf{t}.json").read_text())["seed"] for t in ("", "-seed1")]
    assert seeds == [0, 1]
    rows = data["series"]["slide"]["methods"]["morf"]
    assert all(r["repeats"] == 2 and len(set(r["runs"])) == 2 for r in rows)
    assert data["series"]["slide"]["threshold_db"]["morf"] >= BREAKDOWN_DB
    assert "psnr_person_std" in (out / "stability.md").read_text()
