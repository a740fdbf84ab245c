"""``morf synth`` and ``morf fit`` take ``--config JSON`` and ``--set FIELD=VALUE`` like ``morf train``:
the settings reach the config the stage writes, a bad one is a one-line error that writes nothing,
and the file a stage wrote starts the same stage again."""

from __future__ import annotations

import json

import pytest

from morf.cli.main import main

TINY_SYNTH = ["--preset", "tiny", "--set", "frames=3", "--set", "holdout_frames=0", "--set", "size=64",
              "--set", "texture_size=128"]


def _one_error_line(capsys, *words):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and all(w in err[0] for w in words), err


@pytest.fixture(scope="module")
def synth_project(tmp_path_factory, gl):
    root = tmp_path_factory.mktemp("stage-options") / "capture"
    assert main(["synth", str(root), *TINY_SYNTH, "--set", "shading=0.3", "--set", "background=[0,0,0]"]) == 0
    return root


def test_synth_set_reaches_the_written_config_and_its_file_starts_it_again(synth_project, tmp_path):
    written = json.loads((synth_project / "ground_truth" / "synth_config.json").read_text())["config"]
    assert (written["frames"], written["size"], written["shading"], written["background"]) == (3, 64, 0.3, [0, 0, 0])
    again = tmp_path / "again"
    assert main(["synth", str(again), "--config", str(synth_project / "ground_truth" / "synth_config.json"),
                 "--seed", "4", "--set", "sway=0"]) == 0
    back = json.loads((again / "ground_truth" / "synth_config.json").read_text())["config"]
    assert back == {**written, "seed": 4, "sway": 0.0}


@pytest.mark.parametrize("setting, words", [
    ("framez=3", "unknown config field 'framez'"),
    ("frames=many", "frames"),
    ("frames=0", "--frames must be at least 1"),
    ("shape=[0.5]", "shape must be 6 values"),
])
def test_synth_bad_settings_are_one_line_and_write_nothing(tmp_path, capsys, setting, words):
    root = tmp_path / "bad"
    assert main(["synth", str(root), "--preset", "tiny", "--set", setting]) == 2
    _one_error_line(capsys, words)
    assert not root.exists()


def test_synth_config_and_preset_are_exclusive(synth_project, tmp_path, capsys):
    cfg = synth_project / "ground_truth" / "synth_config.json"
    assert main(["synth", str(tmp_path / "x"), "--config", str(cfg), "--preset", "tiny"]) == 2
    _one_error_line(capsys, "--set")
    assert not (tmp_path / "x").exists()


def test_fit_set_config_and_bad_fields(synth_project, capsys):
    fits = synth_project / "fits"
    assert main(["fit", str(synth_project), "--preset", "tiny", "--set", "nope=1"]) == 2
    _one_error_line(capsys, "unknown config field 'nope'")
    assert main(["fit", str(synth_project), "--preset", "tiny", "--set", "stages.5.iterations=1"]) == 2
    _one_error_line(capsys, "stages.5.iterations")
    assert main(["fit", str(synth_project), "--preset", "tiny", "--set", "temporal_weight=-1"]) == 2
    _one_error_line(capsys, "temporal_weight must be >= 0")
    assert not fits.exists()

    assert main(["fit", str(synth_project), "--preset", "tiny", "--no-overlays", "--device", "cpu",
                 "--set", "stages.0.iterations=2", "--set", "stages.1.iterations=2", "--set", "stages.2.iterations=1",
                 "--set", "temporal_weight=100", "--set", "filter.iou_drop=0.2"]) == 0
    written = json.loads((fits / "fit_config.json").read_text())
    assert [s["iterations"] for s in written["stages"]] == [2, 2, 1]
    assert (written["temporal_weight"], written["filter"]["iou_drop"], written["overlays"]) == (100.0, 0.2, False)
    capsys.readouterr()
    # the file the fit wrote starts the same fit: nothing left to do
    assert main(["fit", str(synth_project), "--config", str(fits / "fit_config.json"), "--device", "cpu"]) == 0
    assert "complete for this configuration" in capsys.readouterr().out
    assert json.loads((fits / "fit_config.json").read_text()) == written
