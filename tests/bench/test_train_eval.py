"""The playback speed a sweep point's row gets from ``morf.bench.train_eval``."""

from __future__ import annotations

import json

import pytest

from morf.bench import train_eval
from morf.bench.train_eval import PlaybackSpeed, measure_speed, speed_of_run


def test_fp32_speed_has_no_int8_comparison():
    fp32 = PlaybackSpeed.from_dict({"fps": 50.0, "frame_ms": 20.0, "renderer_ms": 12.0})
    assert fp32.int8_psnr_vs_fp32_image_db is None
    assert json.dumps(fp32.to_dict()) == json.dumps({"fps": 50.0, "frame_ms": 20.0, "renderer_ms": 12.0})
    int8 = PlaybackSpeed(60.0, 1000 / 60, 9.0, 40.0)
    assert list(int8.to_dict()) == ["fps", "frame_ms", "renderer_ms", "int8_psnr_vs_fp32_image_db"]
    assert PlaybackSpeed.from_dict(int8.to_dict()) == int8


@pytest.fixture
def measured(monkeypatch):
    """The playback benchmark's measurement replaced by a fixed one (as its child writes it)."""
    import morf.bench.render as render

    kernels = {"ops": {}, "kind_share": {}, "composite_share": None}
    m = {"breakdown_ms": {"renderer_ms": 4.0}, "renderer_only_ms": 5.0, "peak_rss_mb": 300.0, "kernels": kernels,
         "threads": 2, "frame_ms": 10.0, "fps_end_to_end": 100.0, "frame_ms_pipelined": 8.0, "fps_pipelined": 125.0,
         "int8_psnr_vs_fp32_image_db": 41.5}
    monkeypatch.setattr(render, "measure_in_child", lambda avatar, size, frames: json.loads(json.dumps(m)))


def test_int8_speed_is_the_playback_benchmarks_measurement(measured, tmp_path):
    assert measure_speed(tmp_path, 64, 10, "int8") == PlaybackSpeed(100.0, 10.0, 5.0, 41.5)


def test_a_runs_speed_row_keeps_its_keys(measured, tmp_path, monkeypatch):
    avatar = tmp_path / "work" / "avatar-run-64"
    avatar.mkdir(parents=True)
    (avatar / "manifest.json").write_text(json.dumps({"int8_quality": {"psnr_db": 38.0}}))
    monkeypatch.setattr(train_eval, "export_for_speed", lambda *a: pytest.fail("the export exists"))
    row = speed_of_run(tmp_path / "runs" / "run", tmp_path / "work", 64, 10, "int8", None)
    assert json.dumps(row) == json.dumps({"fps": 100.0, "frame_ms": 10.0, "renderer_ms": 5.0,
                                          "int8_psnr_vs_fp32_image_db": 41.5, "int8_psnr_vs_fp32_db": 38.0})
