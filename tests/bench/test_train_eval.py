"""What a sweep point's row gets from ``morf.bench.train_eval``: the training's hold-out scores and
the playback speed."""

from __future__ import annotations

import json

import pytest

from morf.bench import train_eval
from morf.bench.train_eval import PlaybackSpeed, RunSpeed, TrainEvaluation, measure_speed, speed_of_run


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
    speed = speed_of_run(tmp_path / "runs" / "run", tmp_path / "work", 64, 10, "int8", None)
    assert speed == RunSpeed(PlaybackSpeed(100.0, 10.0, 5.0, 41.5), 38.0)
    assert json.dumps(speed.to_dict()) == json.dumps({"fps": 100.0, "frame_ms": 10.0, "renderer_ms": 5.0,
                                                      "int8_psnr_vs_fp32_image_db": 41.5, "int8_psnr_vs_fp32_db": 38.0})
    assert RunSpeed.from_dict(speed.to_dict()) == speed


METRICS = {"psnr": 22.0, "ssim": 0.9, "psnr_person": 18.0, "ssim_person": 0.8, "temporal": 0.01}


def test_a_training_that_raised_keeps_its_keys():
    ev = TrainEvaluation(1234, True, error="loss went NaN at step 3")
    want = {"diverged": True, "error": "loss went NaN at step 3", "params": 1234, "psnr": None, "ssim": None,
            "psnr_person": None, "ssim_person": None, "temporal": None, "train_minutes": None, "steps": None}
    assert json.dumps(ev.to_dict()) == json.dumps(want)
    assert TrainEvaluation.from_dict(json.loads(json.dumps(ev.to_dict()))) == ev


def test_a_scored_training_keeps_its_keys():
    ev = TrainEvaluation(1234, False, *METRICS.values(), 1.5, 60, background=(0.5, 0.25, 1.0), frames=3,
                         run="/p/runs/r", eval_resolution=64)
    want = {**METRICS, "background": [0.5, 0.25, 1.0], "frames": 3, "diverged": False, "params": 1234,
            "train_minutes": 1.5, "steps": 60, "run": "/p/runs/r", "eval_resolution": 64}
    assert json.dumps(ev.to_dict()) == json.dumps(want)
    assert TrainEvaluation.from_dict(json.loads(json.dumps(ev.to_dict()))) == ev
    # saved before the scoring size was kept: read and written back as it was
    older = {k: v for k, v in want.items() if k != "eval_resolution"}
    assert json.dumps(TrainEvaluation.from_dict(older).to_dict()) == json.dumps(older)
