"""``morf bench web`` in headless Chromium: the report names what review asked of it (the page's
window, the canvas part of the composite, the browser's CPU time per kind of process, why the
adaptive size settled, the flags used), and a comparison of two page settings measured in turn."""

from __future__ import annotations

import json

import pytest

pytestmark = pytest.mark.gl


def test_bench_reports_window_canvas_cpu_adaptive_reason_and_flags(tail_web, tmp_path):
    from morf.bench.web import WebOptions, run_web

    r = run_web(WebOptions(str(tail_web.path), str(tmp_path / "o"), size=256, frames=4, timeout=600))
    md = (tmp_path / "o" / "web.md").read_text()
    page = r["page"]
    assert page["messages"] == [] and page["tail"] == "js" and page["skin"] == "cpu" and page["display"] == "2d"
    shapes = page["window"]["shapes"]
    assert sum(shapes.values()) == 4 and all("x" in k for k in shapes), shapes
    assert f"shapes {next(iter(shapes))}" in md or next(iter(shapes)) in md
    assert "(of composite: the canvas)" in md and page["parts_ms"]["show"] >= 0
    assert "(of composite: the colour fill)" in md and page["parts_ms"]["fill"] > 0  # fill.js ran
    assert all(ms > 0 for ms in r["host_loop_ms"]) and "The host's speed: a fixed Python loop took" in md
    assert r["steal_share"] is None or (0 <= r["steal_share"] <= 1 and "(steal)" in md)
    cpu = r["played_cpu"]  # marks around the played frames: the browser's CPU time in them, per process kind
    assert cpu and cpu["cpu_s"] > 0 and cpu["by_process"].get("renderer", 0) > 0, cpu
    assert cpu["by_thread"].get("renderer main", 0) > 0 and "Its busiest threads" in md, cpu["by_thread"]
    assert "The browser's CPU time while it played" in md and "renderer" in md
    assert "settled because: " in md and page["adaptive"]["why"], page["adaptive"]
    assert "Flags: crop=the page default, proxy=off, compare=none" in md
    json.loads((tmp_path / "o" / "web.json").read_text())


def test_bench_compares_two_settings_in_turn(tail_web, tmp_path):
    from morf.bench.web import WebOptions, run_web

    r = run_web(WebOptions(str(tail_web.path), str(tmp_path / "o"), size=256, frames=2, compare="path:gl,js",
                           crop="off", timeout=600))
    c = r["page"]["compare"]
    assert c["key"] == "path" and set(c) >= {"gl", "js"} and r["page"]["messages"] == []
    for v in ("gl", "js"):
        assert len(c[v]) and c[v]["raster"]["best"] > 0 and c[v]["wall"]["median"] > 0, c[v]
    md = (tmp_path / "o" / "web.md").read_text()
    assert "gl against js" in md and "| raster |" in md and "compare=path:gl,js" in md and "crop=off" in md
    # played: the wall time and the browser's CPU time per setting (the page marks each turn)
    r = run_web(WebOptions(str(tail_web.path), str(tmp_path / "p"), size=256, frames=4, compare="skin:cpu,gpu",
                           block=2, played=True, timeout=600))
    assert set(r["compare_cpu"]) == {"cpu", "gpu"} and all(v["cpu_s"] > 0 for v in r["compare_cpu"].values())
    assert "CPU ms a frame: all" in (tmp_path / "p" / "web.md").read_text()


def test_bench_flags_reach_the_library_and_bad_ones_are_one_line(tmp_path, monkeypatch, capsys):
    import morf.bench.web as web
    from morf.cli.main import main

    seen = []
    monkeypatch.setattr(web, "run_web", lambda opts: seen.append(opts) or {})
    assert main(["bench", "web", str(tmp_path), "--out", str(tmp_path / "o"), "--crop", "off", "--proxy",
                 "--compare", "canvas:2d,gl", "--block", "4", "--played"]) == 0
    assert seen == [web.WebOptions(str(tmp_path), str(tmp_path / "o"), crop="off", proxy=True, compare="canvas:2d,gl",
                                   block=4, played=True)]
    monkeypatch.undo()
    from morf.web.browser import missing_browser

    if missing_browser():
        pytest.skip("the option checks come after the browser's")
    for flag, value, word in (("--crop", "wide", "--crop"), ("--compare", "skin", "--compare")):
        assert main(["bench", "web", str(tmp_path), "--out", str(tmp_path / "o"), flag, value]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and word in err[0] and "Traceback" not in err[0], err


def test_bench_compares_two_forms_of_the_renderer_graph(tail_avatar, tail_web, tmp_path):
    from morf.bench.web import WebOptions, run_web
    from morf.errors import InputError

    r = run_web(WebOptions(str(tail_avatar), str(tmp_path / "o"), size=256, frames=2, compare="graph:matmul,web", timeout=600))
    c = r["page"]["compare"]
    assert c["key"] == "graph" and r["page"]["messages"] == [], r["page"]
    assert all(c[v]["renderer"]["best"] > 0 for v in ("matmul", "web"))
    assert "matmul against web" in (tmp_path / "o" / "web.md").read_text()
    # the colour fill in the graph against the folder's own graph (the fill in the page)
    r = run_web(WebOptions(str(tail_avatar), str(tmp_path / "s"), size=256, frames=2, compare="graph:web,shipped", timeout=600))
    c = r["page"]["compare"]
    assert r["page"]["messages"] == [] and all(c[v]["renderer"]["best"] > 0 for v in ("web", "shipped"))
    with pytest.raises(InputError, match="graph:A,B takes an avatar folder"):  # a web folder has only its own form
        run_web(WebOptions(str(tail_web.path), str(tmp_path / "p"), compare="graph:matmul,web"))
    with pytest.raises(InputError, match="forms of matmul"):
        run_web(WebOptions(str(tail_avatar), str(tmp_path / "q"), compare="graph:matmul,other"))


def test_bench_profiles_the_renderer_per_node(tail_web, tmp_path):
    from morf.cli.main import main

    assert main(["bench", "web", str(tail_web.path), "--out", str(tmp_path / "o"), "--size", "256", "--frames", "3",
                 "--profile", "--timeout", "600"]) == 0
    p = json.loads((tmp_path / "o" / "web.json").read_text())["profile"]
    assert p["runs"] >= 3 and p["node_ms"] > 0 and abs(sum(p["by_op"].values()) - p["node_ms"]) < 1e-6 * p["node_ms"] + 1e-9
    # the folder's rewritten graph ran: the head's MatMuls as Conv, the colour fill left to the page
    assert "MatMul" not in p["by_op"] and "AveragePool" not in p["by_op"] and any("Conv" in k for k in p["by_op"]), p["by_op"]
    md = (tmp_path / "o" / "web.md").read_text()
    assert "onnxruntime-web's profiler" in md and "profile=on" in md and "The most expensive nodes" in md
