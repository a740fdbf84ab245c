"""``morf bench NAME ...``: each command line turns its options into one call of the library's
benchmark (``morf/bench/``), which has no command-line code of its own."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from morf.cli.main import main

BENCH = Path(__file__).resolve().parents[2] / "morf" / "bench"


def _called(monkeypatch, module: str, function: str) -> list:
    """Replace ``module.function`` by a recorder; the calls it gets, as (args, kwargs)."""
    import importlib

    calls = []
    monkeypatch.setattr(importlib.import_module(module), function,
                        lambda *a, **kw: calls.append((a, kw)) or {"passed": 1, "rows": [{}]})
    return calls


def test_the_library_of_benchmarks_parses_no_command_lines():
    for path in sorted(BENCH.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        imported |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
        assert "argparse" not in imported, path.name
        names = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        assert not {"add_arguments", "run"} & names, f"{path.name} defines a command line: {names}"


def test_step_options_reach_the_library(tmp_path, monkeypatch):
    from morf.bench.step import StepOptions

    calls = _called(monkeypatch, "morf.bench.step", "run_step")
    assert main(["bench", "step", "--out", str(tmp_path), "--preset", "tiny", "--method", "anr", "--steps", "3",
                 "--warmup", "0"]) == 0
    assert calls == [((StepOptions(str(tmp_path), None, "tiny", "anr", 3, 0),), {})]


def test_render_options_reach_the_library(tmp_path, monkeypatch):
    from morf.bench.render import RenderOptions

    calls = _called(monkeypatch, "morf.bench.render", "run_render")
    assert main(["bench", "render", "--out", str(tmp_path), "--size", "128", "--no-variants", "--raster", "cpu"]) == 0
    ((opts,), _), = calls
    assert opts == RenderOptions(str(tmp_path), None, 128, 60, variants=False, raster="cpu", no_amx=False,
                                 command=opts.command)


def test_fitting_options_reach_the_library(tmp_path, monkeypatch):
    from morf.bench.fitting import ABLATION, FittingOptions

    calls = _called(monkeypatch, "morf.bench.fitting", "run_fitting")
    assert main(["bench", "fitting", "--out", str(tmp_path), "--configs", " baseline, all ,", "--set", "a=1",
                 "--set", "b=2"]) == 0
    assert calls == [((FittingOptions(str(tmp_path), settings=("a=1", "b=2"), configs=("baseline", "all")),), {})]
    assert main(["bench", "fitting", "--out", str(tmp_path)]) == 0
    assert calls[1][0][0].configs == tuple(ABLATION)


def test_resume_exit_code_says_whether_every_kill_passed(tmp_path, monkeypatch):
    import morf.bench.resume as resume

    results = iter([{"passed": 2, "rows": [{}, {}]}, {"passed": 1, "rows": [{}, {}]}])
    seen = []
    monkeypatch.setattr(resume, "run_resume", lambda opts: seen.append(opts) or next(results))
    assert main(["bench", "resume", "--out", str(tmp_path), "--kills", "2", "--keep"]) == 0
    assert main(["bench", "resume", "--out", str(tmp_path), "--kills", "2"]) == 1
    assert seen[0] == resume.ResumeOptions(str(tmp_path), kills=2, keep=True) and not seen[1].keep


def test_web_options_reach_the_library(tmp_path, monkeypatch):
    from morf.bench.web import WebOptions

    calls = _called(monkeypatch, "morf.bench.web", "run_web")
    assert main(["bench", "web", str(tmp_path), "--out", str(tmp_path / "o"), "--no-isolation", "--tail", "js"]) == 0
    assert calls == [((WebOptions(str(tmp_path), str(tmp_path / "o"), isolation=False, tail="js"),), {})]


def test_sweep_and_stability_lists_reach_the_library(tmp_path, monkeypatch):
    sweep = _called(monkeypatch, "morf.bench.pareto", "run_sweep")
    assert main(["bench", "pareto", "--out", str(tmp_path), "--preset", "tiny", "--axes", "texture_size, seed",
                 "--points", "base", "--seeds", "2"]) == 0
    (args, kw), = sweep
    assert args[1:] == ("tiny", "print", None, ["texture_size", "seed"])
    assert kw["points"] == ["base"] and kw["seeds"] == 2 and kw["cpus_per_task"] is None
    stability = _called(monkeypatch, "morf.bench.stability", "run_stability")
    assert main(["bench", "stability", "--out", str(tmp_path), "--series", "slide,views", "--methods", "morf"]) == 0
    (args, kw), = stability
    assert args[2:] == (["slide", "views"], ["morf"]) and kw["repeats"] == 1 and kw["cpus_per_task"] == 1


def test_auto_check_gets_the_scenes_and_refuses_the_sweeps_task_options(tmp_path, monkeypatch, capsys):
    import morf.scale.ray_runtime as ray_runtime

    monkeypatch.setattr(ray_runtime, "connect", lambda options=None: None)
    calls = _called(monkeypatch, "morf.bench.auto_check", "auto_check")
    assert main(["bench", "pareto", "--auto-check", "--out", str(tmp_path), "--preset", "tiny",
                 "--scenes", "print", "--points", "texture-32"]) == 0
    (args, kw), = calls
    assert args[1] == "tiny" and kw["scenes"] == ["print"] and kw["points"] == ["texture-32"]
    assert main(["bench", "pareto", "--auto-check", "--out", str(tmp_path), "--workers", "2"]) == 2
    assert "do not apply to --auto-check" in capsys.readouterr().err
    assert len(calls) == 1


@pytest.mark.parametrize("argv, message", [
    (["fitting", "--configs", "baseline,nope"], "unknown fitting configs: nope"),
    (["step", "--steps", "0"], "--steps must be at least 1"),
    (["resume", "--kills", "0"], "--kills must be at least 1"),
    (["stability", "--repeats", "0"], "--repeats must be at least 1"),
])
def test_bad_options_are_one_line_errors_before_any_work(tmp_path, capsys, argv, message, monkeypatch):
    import morf.body

    monkeypatch.setattr(morf.body, "load_body_model", lambda *a, **kw: pytest.fail("loaded the body model"))
    rc = main(["bench", argv[0], "--out", str(tmp_path / "out"), *argv[1:]])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0], err
    assert not (tmp_path / "out").exists()
