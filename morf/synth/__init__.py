"""Synthetic captures: a rendered person with known pose, shape, clothing and camera, written
as an ordinary capture project plus ``ground_truth/`` (see :mod:`morf.synth.capture`).

Names load from their submodule on first use: the preset registry (and so every ``morf`` command
line) reads ``morf.synth.config`` without bringing in the renderer and torch.
"""

from morf.lazy import lazy_attributes

__all__ = ["PRESETS", "SynthConfig", "make_synthetic_capture", "synth_config"]
__getattr__, __dir__ = lazy_attributes(__name__, {
    "make_synthetic_capture": "morf.synth.capture", "PRESETS": "morf.synth.config",
    "SynthConfig": "morf.synth.config", "synth_config": "morf.synth.config"})
