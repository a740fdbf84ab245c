"""The named presets of every stage in one registry: ``PRESETS[stage][name]`` is that stage's config.

Each pipeline stage defines its presets beside its config dataclass (``morf/synth/config.py``,
``morf/fitting/config.py``, ``morf/train/config.py``). Whole commands have presets of their own,
made of the stages' presets plus overrides; since the registry sits below the commands that run
them (docs/architecture.md), their tables and dataclasses are plain data in this package:
``morf/presets/demo.py`` (``morf demo``), ``morf/presets/stability.py`` (``morf bench stability``)
and ``morf/presets/sweep.py`` (``morf bench pareto`` and its ``--auto-check``). This module puts all
those tables side by side, so that the CLI, the benchmarks and the studio look a preset up the same
way (an unknown name is an InputError listing the known ones) and pick the same one when none is
named. The tables are the stages' own dicts, not copies.
"""

from __future__ import annotations

from typing import Any, Mapping

from morf.errors import InputError
from morf.fitting.config import PRESETS as FIT_PRESETS
from morf.presets.demo import PRESETS as DEMO_PRESETS
from morf.presets.stability import PRESETS as STABILITY_PRESETS
from morf.presets.sweep import PRESETS as SWEEP_PRESETS
from morf.synth.config import PRESETS as SYNTH_PRESETS
from morf.train.config import PRESETS as TRAIN_PRESETS

# stage -> {preset name -> config}: SynthConfig, FitConfig, TrainConfig, DemoPreset, StabilityPreset, SweepPreset
PRESETS: Mapping[str, Mapping[str, Any]] = {
    "synth": SYNTH_PRESETS,  # morf synth
    "fit": FIT_PRESETS,  # morf fit
    "train": TRAIN_PRESETS,  # morf train (besides "auto", which is chosen from the capture: morf.sizing)
    "demo": DEMO_PRESETS,  # morf demo
    "stability": STABILITY_PRESETS,  # morf bench stability
    "sweep": SWEEP_PRESETS,  # morf bench pareto (and its --auto-check)
}
# the names every pipeline stage (synth, fit, train) answers to, so that one name can go to each
# stage: "tiny" for tests, "cpu" / "gpu" for the device a run is on (the same config for synth and fit)
COMMON_NAMES = ("tiny", "cpu", "gpu")
# stage -> the preset it runs with when none is named, where that is not "default" (training: by device)
DEFAULTS: Mapping[str, str] = {"demo": "quick"}


def presets_of(stage: str) -> Mapping[str, Any]:
    """The preset table of ``stage``; an unknown stage is an InputError listing the known ones."""
    if stage not in PRESETS:
        raise InputError(f"no presets for stage {stage!r}; stages with presets: {', '.join(PRESETS)}")
    return PRESETS[stage]


def preset(stage: str, name: str) -> Any:
    """The config of preset ``name`` of ``stage``; an unknown name is an InputError listing the known ones."""
    table = presets_of(stage)
    if name not in table:
        raise InputError(f"unknown {stage} preset {name!r}; choose one of {', '.join(table)}")
    return table[name]


def default_preset(stage: str) -> str:
    """The preset ``stage`` runs with when none is named: "gpu" for training when CUDA is present,
    "cpu" for training without it, "quick" for the demo, "default" for the other stages. For synth
    and fit, "default" is the device's preset by another name (cpu and gpu are one config there),
    kept so that what a stage records (a capture's preset) stays what it always was."""
    presets_of(stage)
    if stage == "train":
        import torch

        return "gpu" if torch.cuda.is_available() else "cpu"
    return DEFAULTS.get(stage, "default")
