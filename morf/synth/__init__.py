"""Synthetic captures: a rendered person with known pose, shape, clothing and camera, written
as an ordinary capture project plus ``ground_truth/`` (see :mod:`morf.synth.capture`).

Names load from their submodule on first use: the preset registry (and so every ``morf`` command
line) reads ``morf.synth.config`` without bringing in the renderer and torch.
"""

import importlib

_LAZY = {"make_synthetic_capture": "morf.synth.capture", "PRESETS": "morf.synth.config",
         "SynthConfig": "morf.synth.config", "synth_config": "morf.synth.config"}

__all__ = ["PRESETS", "SynthConfig", "make_synthetic_capture", "synth_config"]


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'morf.synth' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
