"""Detail scores in eval.json, in morf eval's table, on the head sheet and in morf bench quality's page."""

import json

import numpy as np

from morf.evaluate.results import EvalResult, RunScores, TargetEntry, TargetScores

DETAIL = {"person_psnr": 20.0, "person_ssim_shift": 0.81, "person_gmsd": 0.15, "person_hf_ratio": 0.55,
          "person_count": 4, "head_psnr": 19.0, "head_ssim_shift": 0.72, "head_gmsd": 0.18, "head_hf_ratio": 0.41,
          "head_count": 4, "hands_psnr": None, "hands_ssim_shift": None, "hands_gmsd": None, "hands_hf_ratio": None,
          "hands_count": 0, "resolution": 512, "max_shift": 4}


def _scores(detail, head=0.72):
    d = None if detail is None else {**detail, "head_ssim_shift": head}
    return TargetScores(psnr=20.0, ssim=0.9, psnr_person=18.0, ssim_person=0.7, temporal=0.05,
                        background=(0.5, 0.5, 0.5), frames=4, lpips=None, lpips_person=None, resolution=256,
                        detail=d)


def _result(detail=DETAIL):
    entry = TargetEntry("novel poses", None, (0, 1, 2, 3), (0, 3), ("real", "a", "rgb"), 0.5, "s.png", (10, 10),
                        "y.png", (10, 10), "heads-novel-poses.png" if detail else None, (20, 20) if detail else None)
    runs = {"a": RunScores("morf", 0, 256, "fits", False, {"novel-poses": _scores(detail)}),
            "rgb": RunScores("rgb", 0, 256, "fits", True, {"novel-poses": _scores(detail, 0.6)})}
    return EvalResult("p", "training", "", runs, {}, {"novel-poses": entry})


def test_detail_reads_back_and_is_a_metric():
    ev = _result()
    d = ev.to_dict()
    assert d["runs"]["a"]["targets"]["novel-poses"]["detail"]["head_ssim_shift"] == 0.72
    assert d["targets"]["novel-poses"]["heads"] == "heads-novel-poses.png"
    back = EvalResult.from_dict(json.loads(json.dumps(d)))
    assert json.dumps(back.to_dict()) == json.dumps(d)
    m = back.scores("a", "novel-poses")
    assert m.metric("head_ssim_shift") == 0.72 and m.metric("hands_gmsd") is None and m.metric("psnr") == 20.0
    plain = _result(None).to_dict()
    assert "detail" not in plain["runs"]["a"]["targets"]["novel-poses"] and "heads" not in plain["targets"]["novel-poses"]
    assert EvalResult.from_dict(plain).scores("a", "novel-poses").metric("head_gmsd") is None


def test_table_shows_the_detail_block():
    from morf.evaluate.project_eval import format_table

    text = format_table(_result())
    assert "detail at native size (512 px, shift +-4 px)" in text
    row = [line for line in text.splitlines() if line.strip().startswith("rgb") and "0.600" in line]
    assert row and "n/a" in row[0]  # the floor's head SSIM, and no hands scored
    assert "detail at native size" not in format_table(_result(None))


def test_head_sheet_has_one_cell_per_column_and_row():
    from morf.evaluate.sheet import HEAD_CELL, LABEL_H, head_sheet

    crop = np.full((40, 40, 3), 200, np.uint8)
    image = head_sheet([(("real",), {0: crop, 3: crop}), (("a",), {0: crop})], [0, 3], ["frame 0", "frame 3"])
    assert image.shape == (LABEL_H + 2 * HEAD_CELL, 2 * HEAD_CELL, 3)
    assert image[LABEL_H + HEAD_CELL + 5:, HEAD_CELL + 5:].max() < 100  # a missing crop stays blank
    assert image[LABEL_H + HEAD_CELL + 20:, 20:HEAD_CELL - 5].min() == 200


def test_quality_page_compares_methods_on_the_detail_scores():
    from morf.bench.quality_checks import block_checks, training_checks
    from morf.bench.quality_report import quality_markdown
    from morf.bench.quality_runs import BenchRun
    from morf.bench.quality_scores import DETAIL_METRICS, block_scores

    runs = [BenchRun("morf", 0, "a"), BenchRun("rgb", 0, "rgb")]
    block = block_scores(_result(), "novel-poses", runs)
    assert block.heads == "heads-novel-poses.png" and block.to_dict()["heads"] == block.heads
    assert set(DETAIL_METRICS) <= set(block.methods["morf"].mean)
    assert block.methods["morf"].mean["head_ssim_shift"] == 0.72 and block.methods["rgb"].mean["head_ssim_shift"] == 0.6
    head = {"preset": "tiny", "fits": "fits", "holdout": 0, "seeds": 1, "project": "p"}
    md = quality_markdown(head, [(block, block_checks(block, "rgb"))], runs, training_checks(None))
    assert "| method | head_ssim_shift |" in md and "| morf | 0.72 |" in md and "(heads-novel-poses.png)" in md
    plain = block_scores(_result(None), "novel-poses", runs)
    md = quality_markdown(head, [(plain, block_checks(plain, "rgb"))], runs, training_checks(None))
    # no detail scores: no detail table, no crops; the detail targets read "not measured"
    assert "| method | head_ssim_shift |" not in md and "heads-" not in md
    assert "| morf | 0.72 |" not in md
