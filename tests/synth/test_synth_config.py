"""The synthetic capture config follows the training config's rules: it reads back from JSON,
unknown keys and preset names are user errors that say what is known, nonsense is refused."""

from __future__ import annotations

import dataclasses
import json

import pytest

from morf.errors import InputError
from morf.synth.config import PRESETS, SynthConfig, synth_config


@pytest.mark.parametrize("name", list(PRESETS))
def test_every_preset_survives_a_round_trip_through_json(name):
    cfg = synth_config(name, shape=(0.5, 0.4, 0.6, 0.5, 0.5, 0.3))
    back = SynthConfig.from_dict(json.loads(json.dumps(cfg.to_dict())))
    assert back == cfg and isinstance(back.shape, tuple) and isinstance(back.background, tuple)


def test_unknown_keys_and_presets_are_named():
    with pytest.raises(InputError, match=r"unknown synth config keys: \[.fov., .framez.\]"):
        SynthConfig.from_dict({**SynthConfig().to_dict(), "framez": 3, "fov": 30})
    with pytest.raises(InputError, match=r"unknown synth config keys: \[.framez.\]"):
        synth_config("tiny", framez=3)
    with pytest.raises(InputError, match="unknown synth preset 'huge'; choose one of tiny, default"):
        synth_config("huge")


@pytest.mark.parametrize("change, words", [
    ({"sway": -1.0}, "sway must be >= 0"),
    ({"shading": 1.5}, "shading must be in"),
    ({"msaa": -1}, "msaa must be >= 0"),
    ({"background": (300, 0, 0)}, "background must be 3 values"),
    ({"background": (0, 0)}, "background must be 3 values"),
    ({"frames": 0}, "--frames must be at least 1"),
])
def test_validate_refuses_nonsense(change, words):
    with pytest.raises(InputError, match=words):
        dataclasses.replace(SynthConfig(), **change).validate()
    with pytest.raises(InputError, match=words):
        SynthConfig.from_dict({**SynthConfig().to_dict(), **change})
