"""``morf bench studio``: the real studio, headless, playing a tiny avatar; and its command line."""

from __future__ import annotations

import json

import pytest

from studio import bench
from tests.conftest import require


def test_morf_bench_studio_hands_every_argument_to_the_studio_benchmark():
    from morf.cli.main import build_parser

    args = build_parser().parse_args(["bench", "studio", "--avatar", "A", "--seconds", "3", "--help"])
    assert args.app_args == ["--avatar", "A", "--seconds", "3", "--help"]


def test_cpu_shares_group_threads_by_role_then_by_whose_helpers_they_are():
    before = {1: ("python", 0, 1.0), 2: ("llvmpipe-0", 0, 0.0), 3: ("python", 0, 0.0), 5: ("python", 10, 0.0)}
    after = {1: ("python", 0, 1.5), 2: ("llvmpipe-0", 0, 0.25), 3: ("python", 0, 0.25), 4: ("llvmpipe-1", 10, 0.25),
             5: ("python", 10, 0.5), 6: ("python", 10, 0.1)}
    shares = bench.cpu_shares(before, after, 1.0, {1: "UI thread", 5: "live render thread"}, helper_nice=10)
    assert shares == pytest.approx({"UI thread": 50.0, "UI: software GL": 25.0, "other threads": 25.0,
                                    "live render: software GL": 25.0, "live render thread": 50.0,
                                    "live render: onnxruntime and numba threads": 10.0})
    assert bench.thread_cpu_seconds()  # this process's own threads (Linux)


@pytest.mark.gl
def test_the_studio_benchmark_plays_an_avatar_and_writes_its_numbers(tiny_avatar_dir, tmp_path):
    require("imgui_bundle")
    shot = tmp_path / "studio.png"
    rc = bench.main(["--avatar", str(tiny_avatar_dir), "--seconds", "1.5", "--warmup", "1", "--headless", "--rounds", "2",
                     "--compare-frames", "2", "--out", str(tmp_path), "--screenshot", str(shot)])
    assert rc == 0 and shot.is_file()
    result = json.loads((tmp_path / "studio.json").read_text())
    s = result["studio"]
    assert s["live_fps"] > 0 and s["ui_fps"] > 0 and s["ui_frame_ms_p95"] > 0
    assert "UI thread" in s["cpu_percent_of_one_core"] and "live render thread" in s["cpu_percent_of_one_core"]
    assert result["window"] == "headless EGL" and result["targets"]["live_fps"] in ("met", "missed")
    typing = result["typing"]  # a path typed key by key into the motion field while it played, then Enter
    assert typing["typed_in_field"] and typing["listed"] and typing["frames"] > typing["keys"] / 2
    assert typing["ui_frame_ms_p99"] > 0 and result["targets"]["typing_p99"] in ("met", "missed")
    b = result["bench_render"]  # the reference, measured before, between and after the two rounds
    assert len(b["fps_each"]) == 3 and min(b["fps_each"]) > 0 and b["fps"] == pytest.approx(sum(b["fps_each"]) / 3)
    assert len(result["rounds"]) == 2
    assert result["live_vs_bench"] == pytest.approx(sum(r["ratio"] for r in result["rounds"]) / 2)


def _window(seconds, live_frames, cpu, steps=None):
    import numpy as np

    return bench.Window(seconds=seconds, ui_frames=10, ui_frame_ms=np.full(10, seconds), live_frames=live_frames,
                        live_shown=live_frames, ui_light_frames=5, live_render_ms=np.full(live_frames, 30.0),
                        cpu=cpu, train_steps=steps)


def test_rounds_are_compared_with_the_references_beside_them_and_merged():
    windows = [_window(2.0, 60, {"UI thread": 20.0}), _window(2.0, 40, {"UI thread": 40.0}),
               _window(4.0, 120, {"UI thread": 10.0, "worker thread": 5.0})]
    refs = [{"fps_end_to_end": f, "frame_ms": 1000 / f, "size": 640} for f in (40.0, 20.0, 40.0, 30.0)]
    out = bench.compare_rounds(windows, refs)
    assert [r["bench_fps"] for r in out["rounds"]] == [30.0, 30.0, 35.0]
    assert [round(r["ratio"], 4) for r in out["rounds"]] == [1.0, round(20 / 30, 4), round(30 / 35, 4)]
    assert out["live_vs_bench"] == pytest.approx(30 / 35)  # the median round
    assert out["bench_render"]["fps_each"] == [40.0, 20.0, 40.0, 30.0] and out["bench_render"]["fps"] == 32.5
    # one window between two references (the studio training meanwhile)
    one = bench.compare_rounds(windows[:1], refs[:2])
    assert one["rounds"][0]["bench_fps"] == 30.0 and one["live_vs_bench"] == 1.0
    merged = bench.merge_windows(windows)
    assert merged.seconds == 8.0 and merged.live_frames == 220 and merged.ui_frames == 30
    assert len(merged.ui_frame_ms) == 30 and merged.train_steps is None
    assert merged.cpu == pytest.approx({"UI thread": 20.0, "worker thread": 2.5})
