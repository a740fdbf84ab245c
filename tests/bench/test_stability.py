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
