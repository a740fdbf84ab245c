"""``morf run`` says which training preset it uses and why, and names the detail preset beside cpu."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from morf.cli.main import main
from morf.cli.run import _run_name, preset_hint
from morf.train.config import DETAIL_PRESET, PRESETS

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "capture"))
from capture_helpers import write_masks, write_openpose, write_video  # noqa: E402


def test_preset_without_runs_is_the_devices_with_the_reason(tmp_path, monkeypatch):
    import torch

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert _run_name(tmp_path, None) == ("morf-cpu", "cpu", "no CUDA device: the few-minute CPU preset")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert _run_name(tmp_path, None) == ("morf-gpu", "gpu", "CUDA is present")


def test_preset_of_the_latest_run_is_named_with_that_run(tmp_path):
    run = tmp_path / "runs" / "faces"
    run.mkdir(parents=True)
    (run / "config.json").write_text(json.dumps(PRESETS[DETAIL_PRESET].to_dict()))
    name, preset, why = _run_name(tmp_path, None)
    assert (name, preset) == ("faces", DETAIL_PRESET) and "latest training run, faces" in why


def test_cpu_names_the_detail_preset_and_others_nothing():
    assert f"--preset {DETAIL_PRESET}" in preset_hint("cpu")
    assert preset_hint(DETAIL_PRESET) == "" and preset_hint("gpu") == ""


def test_run_prints_the_preset_and_why(tmp_path, capsys):
    video = write_video(tmp_path / "clip.avi", 6)
    kp = write_openpose(tmp_path / "kp", 6, [(10, 8, 30, 40)])
    masks = write_masks(tmp_path / "masks", 6)
    root = tmp_path / "proj"
    rc = main(["run", str(root), "--video", str(video), "--keypoints", str(kp), "--masks", str(masks),
               "--until", "ingest", "--preset", "tiny"])
    out = capsys.readouterr().out
    assert rc == 0 and "training preset: tiny (given with --preset)" in out
    rc = main(["run", str(root), "--until", "ingest"])  # no --preset: the one the last morf run chose
    out = capsys.readouterr().out
    assert rc == 0 and "training preset: tiny (the last 'morf run' on this project chose it (run.json))" in out
