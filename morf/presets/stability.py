"""``morf bench stability``'s presets: the clean capture, the training and the nuisance levels.

Plain data (no torch, no numpy): :mod:`morf.presets` registers the table as stage ``stability``
and :mod:`morf.bench.stability` runs it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StabilityPreset:
    """Fields: synth: (synth preset, overrides) of the clean capture; train: (training preset,
    overrides); fit: the fit preset of the keypoints series' captures; levels: per series."""

    synth: tuple[str, dict]
    train: tuple[str, dict]
    fit: str
    levels: dict


PRESETS: dict[str, StabilityPreset] = {
    "tiny": StabilityPreset(("tiny", {"frames": 8, "holdout_frames": 3}),
                            ("tiny", {"steps": 4, "inpaint_steps": 0}), "tiny",
                            {"misalignment": [0, 10], "slide": [0, 0.03], "loose": [0, 0.1], "fast": [1, 2],
                             "keypoints": [0, 15], "coverage": [0, 180]}),
    "default": StabilityPreset(("default", {"frames": 64, "size": 256, "holdout_frames": 16, "detector": "none"}),
                               ("cpu", {"resolution": 128, "steps": 400, "inpaint_steps": 40, "inpaint_views": 8}),
                               "fast",
                               {"misalignment": [0, 2, 5, 10], "slide": [0, 0.006, 0.015, 0.03],
                                "loose": [0, 0.025, 0.06, 0.12], "fast": [1, 2, 4, 8],
                                "keypoints": [0, 3, 8, 15], "coverage": [0, 90, 180, 240]}),
}
