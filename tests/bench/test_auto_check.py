"""``morf bench pareto --auto-check`` on the tiny preset: the automatic choice measured beside the
sizing points, per scene, and the single-scene form on an existing capture."""

import json

import pytest

from morf.bench.auto_check import auto_check
from morf.errors import InputError


@pytest.mark.gl
def test_tiny_auto_check(sweep_dir, print_capture, body_model, gl):
    out = sweep_dir / "auto"
    # both scenes on the tiny sweep's shared capture (each distinct training runs once; making a
    # capture is the conftest's, through the same make_capture), one sizing point beside the base
    # and the choice: what is checked here is the per-scene loop, its sweeps, verdicts and report
    cap = str(print_capture.root)
    res = auto_check(out, "tiny", body_model, scenes=("plain", "print"), project_path={"plain": cap, "print": cap},
                     points=["texture-32"])
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
                       points=["texture-32"])
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
                     points=["texture-32"], seeds=2)
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


def test_auto_check_rejects_bad_scene_lists(tmp_path):
    with pytest.raises(InputError, match="unknown scenes"):
        auto_check(tmp_path, "tiny", scenes=("stripes",))
    with pytest.raises(InputError, match="exactly one scene"):
        auto_check(tmp_path, "tiny", scenes=("plain", "print"), project_path=str(tmp_path))
    with pytest.raises(InputError, match="seeds must be at least 1"):
        auto_check(tmp_path, "tiny", scenes=("print",), seeds=0)


def test_scene_projects_forms():
    from morf.bench.auto_check import scene_projects

    assert scene_projects(["plain", "print"], None) == {"plain": None, "print": None}
    assert scene_projects(["print"], "/cap") == {"print": "/cap"}
    assert scene_projects(["plain", "print", "loose"], "print=/cap, loose=/l") == \
        {"plain": None, "print": "/cap", "loose": "/l"}
    assert scene_projects(["plain", "print"], {"print": "/cap"}) == {"plain": None, "print": "/cap"}
    with pytest.raises(InputError, match="not checked"):
        scene_projects(["plain"], "print=/cap")
    with pytest.raises(InputError, match="scene=PATH"):
        scene_projects(["plain", "print"], "print=")
