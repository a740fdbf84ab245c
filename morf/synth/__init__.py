"""Synthetic captures: a rendered person with known pose, shape, clothing and camera, written
as an ordinary capture project plus ``ground_truth/`` (see :mod:`morf.synth.capture`).
"""

from morf.synth.capture import make_synthetic_capture
from morf.synth.config import PRESETS, SynthConfig, synth_config

__all__ = ["PRESETS", "SynthConfig", "make_synthetic_capture", "synth_config"]
