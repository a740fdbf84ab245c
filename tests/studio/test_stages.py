"""The studio's stage table: the library's stages load by name, take their presets from
``morf.presets`` (with the CLI's default), and a stage that cannot be loaded says why on screen."""

from __future__ import annotations

import time

import pytest

from morf.errors import InputError
from morf.fitting.config import PRESETS as FIT_PRESETS
from morf.train.config import PRESETS as TRAIN_PRESETS
from studio.stages import LIBRARY_STAGES, LibraryStage, load_library_stages, stage_config


def test_the_table_loads_the_library_stages_with_their_presets():
    from morf.presets import default_preset

    loaded = load_library_stages()
    assert [s.name for s in LIBRARY_STAGES] == ["fit", "train", "export"]
    assert loaded.errors == {} and set(loaded.functions) == {"fit", "train", "export"}
    assert loaded.presets == {"fit": tuple(FIT_PRESETS), "train": tuple(TRAIN_PRESETS)}
    assert loaded.default_presets == {"fit": default_preset("fit"), "train": default_preset("train")}


def test_the_studio_defaults_to_the_preset_morf_train_picks(monkeypatch):
    import torch

    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert load_library_stages().default_presets["train"] == "gpu"
    assert stage_config("train", {}) == TRAIN_PRESETS["gpu"]
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert load_library_stages().default_presets["train"] == "cpu"
    assert stage_config("train", {"steps": 7}) == TRAIN_PRESETS["cpu"].replace(steps=7)


def test_a_stage_that_cannot_be_loaded_reports_the_error_and_the_others_load():
    def broken():
        import importlib

        return importlib.import_module("morf_no_such_module")

    table = (LibraryStage("fit", "Fit body", broken, presets=True), LIBRARY_STAGES[2])
    loaded = load_library_stages(table)
    assert loaded.errors == {"fit": "ModuleNotFoundError: No module named 'morf_no_such_module'"}
    assert set(loaded.functions) == {"export"} and loaded.presets == {}


def test_stage_configs_name_what_is_wrong():
    from morf.export.project_export import ProjectExportConfig

    assert stage_config("fit", {"preset": "tiny", "overlays": False}) == FIT_PRESETS["tiny"].replace(overlays=False)
    assert stage_config("export", {"calibration_views": 4}, ProjectExportConfig).calibration_views == 4
    with pytest.raises(InputError, match="unknown fit preset 'huge'; choose one of"):
        stage_config("fit", {"preset": "huge"})
    with pytest.raises(InputError, match="unknown train config fields: stepz"):
        stage_config("train", {"preset": "tiny", "stepz": 3})
    with pytest.raises(InputError, match="the export stage has no presets"):
        stage_config("export", {"preset": "tiny"}, ProjectExportConfig)
    with pytest.raises(InputError, match="chunk_frames"):
        stage_config("fit", {"chunk_frames": 0})


@pytest.mark.gl
def test_the_training_panel_shows_why_a_stage_cannot_be_loaded(make_app, tiny_project, monkeypatch):
    import studio.app
    from studio.commands import StartStage

    def broken():
        raise ImportError("libtorch_cpu.so: cannot open shared object file")

    table = (LibraryStage("fit", "Fit body", broken, presets=True),)
    monkeypatch.setattr(studio.app, "load_library_stages", lambda: load_library_stages(table))
    app = make_app("capture", stages=None, unavailable=None)
    app.settle()
    app.state.select_panel(3)
    app.settle()
    assert "stage-error:fit" in app.state.item_rects  # the error line was drawn
    app.send(StartStage("fit"))
    deadline = time.monotonic() + 10
    while not app.worker.latest().error and time.monotonic() < deadline:
        time.sleep(0.01)
    assert app.worker.latest().error == ("stage 'fit' is not available: "
                                         "ImportError: libtorch_cpu.so: cannot open shared object file")
