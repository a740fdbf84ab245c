"""``morf bench quality`` on the tiny preset through the command line: a fitted capture, two seeds,
both evaluation blocks with the floor, the seed spreads and targets, the images, reuse, bad input."""

import json

import cv2
import pytest

from morf.cli.main import main

PNG = b"\x89PNG\r\n\x1a\n"
LEARNED = ("morf", "stylepeople")


@pytest.mark.slow
@pytest.mark.gl
def test_tiny_quality_bench_over_two_seeds(tmp_path, gl, one_torch_thread):
    from morf.evaluate.sheet import LABEL_H, cell_size

    out = tmp_path / "q"
    assert main(["bench", "quality", "--preset", "tiny", "--out", str(out), "--seeds", "2", "--steps", "3"]) == 0
    data = json.loads((out / "quality.json").read_text())
    assert (data["fits"], data["holdout"], data["seeds"]) == ("fits", 5, 2)
    assert (out / "capture" / "fits" / "fits.npz").is_file()  # the capture was fitted before training
    assert data["methods"] == [*LEARNED, "rgb"]
    assert [r["name"] for r in data["runs"]] == ["bench-morf-tiny", "bench-morf-tiny-s1", "bench-stylepeople-tiny",
                                                 "bench-stylepeople-tiny-s1", "bench-rgb-tiny"]
    assert list(data["blocks"]) == ["novel-poses", "holdout-k5"]
    ev = json.loads((out / "eval.json").read_text())
    for key, block in data["blocks"].items():
        assert list(block["methods"]) == [*LEARNED, "rgb"]
        for m in LEARNED:
            s = block["methods"][m]
            assert [x["run"] for x in s["seeds"]] == [f"bench-{m}-tiny", f"bench-{m}-tiny-s1"]
            person = [x["psnr_person"] for x in s["seeds"]]
            assert s["mean"]["psnr_person"] == pytest.approx(sum(person) / 2)
            assert s["spread"]["psnr_person"] == pytest.approx(max(person) - min(person))
            ssim = [x["ssim_person"] for x in s["seeds"]]
            assert s["spread"]["ssim_person"] == pytest.approx(max(ssim) - min(ssim))
        floor, morf = block["methods"]["rgb"], block["methods"]["morf"]
        assert len(floor["seeds"]) == 1 and floor["spread"]["psnr_person"] is None
        checks = block["checks"]
        assert checks["morf_minus_floor_psnr_person_db"] == pytest.approx(
            morf["mean"]["psnr_person"] - floor["mean"]["psnr_person"])
        assert checks["morf_minus_floor_ssim_person"] == pytest.approx(
            morf["mean"]["ssim_person"] - floor["mean"]["ssim_person"])
        assert checks["morf_seed_spread_db"] == pytest.approx(morf["spread"]["psnr_person"])
        assert checks["targets"]["morf_seed_spread_db"]["want"] == "<= 1"
        assert {"temporal_gain_vs_stylepeople", "psnr_delta_vs_stylepeople_db"} <= set(checks["targets"])
        # real | each method's seed 0 | floor, on the sheet and the y-t slices
        assert ev["targets"][key]["columns"] == ["real", "bench-morf-tiny", "bench-stylepeople-tiny", "bench-rgb-tiny"]
        for name in (block["sheet"], block["slices"]):
            assert (out / name).read_bytes()[:8] == PNG
        sheet = cv2.imread(str(out / block["sheet"]))
        assert sheet.shape[1] == 4 * cell_size([64]) and sheet[LABEL_H:].std() > 5
    assert set(ev["runs"]) == {r["name"] for r in data["runs"]}  # every seed scored
    md = (out / "quality.md").read_text()
    for name in ("sheet-novel-poses.png", "yt-novel-poses.png", "sheet-holdout-k5.png", "yt-holdout-k5.png"):
        assert f"]({name})" in md
    assert md.count("| rgb | 1 |") == 2 and "fitted bodies" in md

    # one seed again: the seed-0 runs are reused, nothing trained; no spread to measure
    stamps = {r: (tmp_path / "q" / "capture" / "runs" / r / "avatar.pt").stat().st_mtime_ns
              for r in ("bench-morf-tiny", "bench-rgb-tiny")}
    assert main(["bench", "quality", "--preset", "tiny", "--out", str(out), "--steps", "3"]) == 0
    again = json.loads((out / "quality.json").read_text())
    assert {r: (out / "capture" / "runs" / r / "avatar.pt").stat().st_mtime_ns for r in stamps} == stamps
    assert again["blocks"]["novel-poses"]["checks"]["morf_seed_spread_db"] is None
    assert "novel-poses: morf_seed_spread_db" in again["targets_not_measured"]
    assert again["poses"] == "given"

    # the same runs scored with refined poses: nothing trained, the protocol said in both files
    assert main(["bench", "quality", "--preset", "tiny", "--out", str(out), "--steps", "3", "--methods", "morf",
                 "--refine-poses"]) == 0
    refined = json.loads((out / "quality.json").read_text())
    assert {r: (out / "capture" / "runs" / r / "avatar.pt").stat().st_mtime_ns for r in stamps} == stamps
    assert refined["poses"] == "refined" and json.loads((out / "eval.json").read_text())["poses"] == "refined"
    assert "refined against the frame" in (out / "quality.md").read_text()


@pytest.mark.parametrize("args, words", [
    (["--methods", "morf,bogus"], "unknown method(s) bogus"),
    (["--seeds", "0"], "--seeds must be at least 1"),
    (["--holdout", "1"], "--holdout must be 0"),
])
def test_bad_options_are_one_line_errors(tmp_path, capsys, args, words):
    rc = main(["bench", "quality", "--preset", "tiny", "--out", str(tmp_path / "q"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and words in err[0]
    assert not (tmp_path / "q").exists()


def test_targets_and_unmeasured_values():
    from morf.bench.quality_checks import Target, block_checks
    from morf.bench.quality_runs import run_name
    from morf.bench.quality_scores import BlockScores, MethodScores

    assert run_name("morf", "cpu") == "bench-morf-cpu" and run_name("morf", "cpu", 2) == "bench-morf-cpu-s2"
    t = Target("x", "<=", 1.0)
    assert t.met(0.5) is True and t.met(1.5) is False and t.met(None) is None

    def scores(method, person, ssim_person, temporal=0.1):
        mean = {"psnr": person + 8, "psnr_person": person, "ssim": 0.9, "ssim_person": ssim_person,
                "temporal": temporal}
        return MethodScores(method, mean, (), {"psnr_person": None, "ssim_person": None})

    block = BlockScores("novel-poses", "t", 4, "s.png", "y.png",
                        {"morf": scores("morf", 24.0, 0.8), "rgb": scores("rgb", 20.0, 0.6)})
    c = block_checks(block, "rgb")
    assert c.values["morf_minus_floor_psnr_person_db"] == pytest.approx(4.0)
    assert c.met["morf_minus_floor_psnr_person_db"] and c.met["morf_minus_floor_ssim_person"]
    assert c.met["morf_seed_spread_db"] is None and c.met["temporal_gain_vs_stylepeople"] is None
    assert c.met["morf_head_hf_ratio_inside"] is None  # no detail scores: not measured, not failed

    def detailed(method, person, head_ssim, hf):
        s = scores(method, person, 0.7)
        return MethodScores(method, {**s.mean, "head_ssim_shift": head_ssim, "head_hf_ratio_inside": hf}, (), s.spread)

    # the blurred avatar wins on PSNR but loses the head detail targets
    blur = block_checks(BlockScores("novel-poses", "t", 4, "s.png", "y.png",
                                    {"morf": detailed("morf", 24.0, 0.70, 0.3), "rgb": detailed("rgb", 20.0, 0.75, 0.9)}), "rgb")
    assert blur.met["morf_minus_floor_psnr_person_db"] is True
    assert blur.met["morf_minus_floor_head_ssim_shift"] is False and blur.met["morf_head_hf_ratio_inside"] is False
    sharp = block_checks(BlockScores("novel-poses", "t", 4, "s.png", "y.png",
                                     {"morf": detailed("morf", 24.0, 0.80, 0.8), "rgb": detailed("rgb", 20.0, 0.75, 0.9)}), "rgb")
    assert sharp.met["morf_minus_floor_head_ssim_shift"] is True and sharp.met["morf_head_hf_ratio_inside"] is True
