"""``morf bench studio``: the real studio, headless, playing a tiny avatar; and its command line."""

from __future__ import annotations

import json

import pytest

from studio import bench


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
                                    "live render: onnxruntime threads": 10.0})
    assert bench.thread_cpu_seconds()  # this process's own threads (Linux)


@pytest.mark.gl
def test_the_studio_benchmark_plays_an_avatar_and_writes_its_numbers(tiny_avatar_dir, tmp_path):
    pytest.importorskip("imgui_bundle")
    shot = tmp_path / "studio.png"
    rc = bench.main(["--avatar", str(tiny_avatar_dir), "--seconds", "1.5", "--warmup", "1", "--headless",
                     "--compare-frames", "2", "--out", str(tmp_path), "--screenshot", str(shot)])
    assert rc == 0 and shot.is_file()
    result = json.loads((tmp_path / "studio.json").read_text())
    s = result["studio"]
    assert s["live_fps"] > 0 and s["ui_fps"] > 0 and s["ui_frame_ms_p95"] > 0
    assert "UI thread" in s["cpu_percent_of_one_core"] and "live render thread" in s["cpu_percent_of_one_core"]
    assert result["window"] == "headless EGL" and result["targets"]["live_fps"] in ("met", "missed")
    b = result["bench_render"]  # the reference, measured before and after the studio
    assert b["fps_before"] > 0 and b["fps_after"] > 0 and b["fps"] == pytest.approx((b["fps_before"] + b["fps_after"]) / 2)
    assert result["live_vs_bench"] == pytest.approx(s["live_fps"] / b["fps"])
