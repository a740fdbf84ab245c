"""The presets of whole commands (``morf demo``, ``morf bench stability``, ``morf bench pareto``;
stages ``demo``, ``stability`` and ``sweep`` of ``morf.presets``) are made of the stages' registered
presets plus overrides: every name they use must be in the registry and every override must make a
valid config, so renaming or reshaping a stage preset fails here instead of in a user's run."""

from __future__ import annotations

import pytest

from morf import presets
from morf.synth.config import synth_config
from morf.train.config import preset as train_preset


def _demo_rows():
    return [(f"demo {name}", p.synth, {}, p.fit, p.train,
             {**({"steps": p.train_steps} if p.train_steps else {}), **dict(p.train_set)})
            for name, p in presets.presets_of("demo").items()]


def test_demo_train_settings_reach_the_train_config():
    """What ``morf demo`` passes as ``--set`` reads back as the preset's typed values."""
    from morf.train.config import preset as train_preset

    p = presets.preset("demo", "quick")
    assert p.train_set and p.train_set_args()[0] == "--set"
    cfg = train_preset(p.train).with_settings(list(p.train_set_args()[1::2]))
    assert all(getattr(cfg, k) == v for k, v in p.train_set)


def _stability_rows():
    return [(f"stability {name}", p.synth[0], p.synth[1], p.fit, p.train[0], p.train[1])
            for name, p in presets.presets_of("stability").items()]


def _sweep_rows():
    return [(f"sweep {name}", p.synth[0], p.synth[1], None, p.train[0], p.train[1])
            for name, p in presets.presets_of("sweep").items()]


@pytest.mark.parametrize("rows", [_demo_rows, _stability_rows, _sweep_rows], ids=["demo", "stability", "sweep"])
def test_command_presets_use_registered_stage_presets(rows):
    for label, synth, synth_over, fit, train, train_over in rows():
        assert synth in presets.presets_of("synth"), label
        synth_config(synth, **synth_over).validate()
        if fit is not None:
            assert fit in presets.presets_of("fit"), label
        assert train in presets.presets_of("train"), label
        train_preset(train, **train_over).validate()


def test_morf_run_hands_its_preset_name_to_the_fit_too():
    """tiny / cpu / gpu name a preset of every stage, so ``morf run --preset NAME`` fits with the fit
    preset NAME (the same config for cpu and gpu); auto is chosen from the capture and fits with the
    default fit."""
    from morf.cli.run import _fit_preset

    for name in presets.COMMON_NAMES:
        assert _fit_preset(name) == name and name in presets.presets_of("fit")
    assert _fit_preset("auto") == presets.default_preset("fit")
    assert presets.preset("fit", "cpu") == presets.preset("fit", "gpu") == presets.preset("fit", "default")
