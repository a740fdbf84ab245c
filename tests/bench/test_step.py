"""``morf bench step``: both bf16 settings timed through the command a user runs."""

import json

import pytest

from morf.bench.step import StepResult, StepTime


def test_step_bench_times_both_settings(tmp_path, body_model, gl):
    from morf.cli.main import main

    assert main(["bench", "step", "--preset", "tiny", "--out", str(tmp_path / "out"), "--steps", "2",
                 "--warmup", "1"]) == 0
    saved = json.loads((tmp_path / "out" / "step.json").read_text())
    res = StepResult.from_dict(saved)
    assert res.to_dict() == saved and saved["benchmark"] == "step"
    assert [r.bf16 for r in res.rows] == [True, False]
    assert all(r.s_per_step > 0 for r in res.rows)
    assert sum(r.chosen_by_trainer for r in res.rows) == 1  # the trainer picks exactly one of them
    assert "native_bf16" in res.machine["cpu_features"]
    assert (tmp_path / "out" / "step.md").is_file()


@pytest.mark.parametrize("argv", [["--steps", "0"], ["--warmup", "-1"]])
def test_step_bench_rejects_bad_counts(tmp_path, argv):
    from morf.cli.main import main

    assert main(["bench", "step", "--preset", "tiny", "--out", str(tmp_path), *argv]) != 0


def test_step_rows_keep_their_keys():
    r = StepResult("tiny", "morf", "/p", 12, 2, (StepTime(True, 0.5, False), StepTime(False, 0.25, True)), {"cpu": "x"})
    d = r.to_dict()
    assert list(d) == ["benchmark", "preset", "method", "project", "frames", "steps", "rows", "machine"]
    assert d["rows"] == [{"bf16": True, "s_per_step": 0.5, "chosen_by_trainer": False},
                         {"bf16": False, "s_per_step": 0.25, "chosen_by_trainer": True}]
    assert StepResult.from_dict(json.loads(json.dumps(d))) == r
