"""``morf.presets``: one registry of every stage's named presets, the preset a stage runs with when
none is named, and the command line looking presets up through it."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from morf import presets
from morf.errors import InputError
from morf.fitting.config import PRESETS as FIT_PRESETS
from morf.fitting.config import FitConfig
from morf.synth.config import PRESETS as SYNTH_PRESETS
from morf.synth.config import SynthConfig
from morf.train.config import PRESETS as TRAIN_PRESETS
from morf.train.config import TrainConfig


def test_the_registry_holds_each_stages_own_table():
    assert dict(presets.PRESETS) == {"synth": SYNTH_PRESETS, "fit": FIT_PRESETS, "train": TRAIN_PRESETS}
    for stage, cls in (("synth", SynthConfig), ("fit", FitConfig), ("train", TrainConfig)):
        table = presets.presets_of(stage)
        assert table is presets.PRESETS[stage] and table
        for name, config in table.items():
            assert isinstance(config, cls)
            assert presets.preset(stage, name) is config
            config.validate()


def test_unknown_stages_and_preset_names_are_input_errors_listing_the_known_ones():
    with pytest.raises(InputError, match="stages with presets: synth, fit, train"):
        presets.preset("paint", "default")
    with pytest.raises(InputError, match="unknown fit preset 'huge'; choose one of default, fast, tiny, baseline"):
        presets.preset("fit", "huge")
    with pytest.raises(InputError, match="unknown train preset 'auto'; choose one of tiny, cpu, gpu"):
        presets.preset("train", "auto")
    with pytest.raises(InputError, match="unknown synth preset 'huge'; choose one of tiny, default"):
        presets.preset("synth", "huge")


def test_the_default_training_preset_follows_the_device(monkeypatch):
    import torch

    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert presets.default_preset("train") == "gpu"
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert presets.default_preset("train") == "cpu"
    assert presets.default_preset("fit") == presets.default_preset("synth") == "default"
    with pytest.raises(InputError, match="stages with presets"):
        presets.default_preset("paint")


def test_morf_train_without_a_preset_uses_the_registrys_default(monkeypatch):
    import torch

    from morf.cli.train import resolve_config

    args = SimpleNamespace(preset=None, method="morf", steps=None, resolution=None, crop=None, batch_size=None,
                           device="cpu", renderer=None)
    for cuda, name in ((True, "gpu"), (False, "cpu")):
        monkeypatch.setattr(torch.cuda, "is_available", lambda cuda=cuda: cuda)
        cfg, _ = resolve_config(args)
        assert cfg == TRAIN_PRESETS[name].replace(device="cpu")


def test_morf_fit_names_the_known_presets_of_an_unknown_one(tmp_path, capsys):
    from morf.capture.project import CaptureProject
    from morf.cli.main import main

    CaptureProject.create(tmp_path / "p", num_frames=1, width=8, height=8, fps=None, source={"kind": "test"})
    assert main(["fit", str(tmp_path / "p"), "--preset", "huge"]) == InputError.exit_code
    assert "unknown fit preset 'huge'; choose one of default, fast, tiny, baseline" in capsys.readouterr().err


def test_replace_refuses_unknown_fields_with_an_input_error():
    with pytest.raises(InputError, match="bogus"):
        TRAIN_PRESETS["cpu"].replace(bogus=1)
    with pytest.raises(InputError, match="bogus"):
        FitConfig().replace(bogus=1)
