"""``morf bench stability``'s presets: the clean capture, the training and the nuisance levels.

Plain data (no torch, no numpy): :mod:`morf.presets` registers the table as stage ``stability``
and :mod:`morf.bench.stability` runs it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ViewsSeries:
    """The fit-only "views" series: the turn captured in a few views, fitted and scored against the
    truth (no training). Fields: synth: (synth preset, overrides) of the capture whose turn is
    subsampled; fit: the fit preset; levels: views kept of the turn; keypoints: the kinds fitted
    ("mediapipe": the detector on the rendered views, "truth": true keypoints plus the preset's
    noise); dense: also fit every frame of the capture, the reference the views are judged by."""

    synth: tuple[str, dict]
    fit: str
    levels: tuple[int, ...]
    keypoints: tuple[str, ...] = ("mediapipe", "truth")
    dense: bool = True


@dataclass(frozen=True)
class StabilityPreset:
    """Fields: synth: (synth preset, overrides) of the clean capture; train: (training preset,
    overrides); fit: the fit preset of the keypoints series' captures; levels: per series;
    views: the fit-only series of a turn in a few views."""

    synth: tuple[str, dict]
    train: tuple[str, dict]
    fit: str
    levels: dict
    views: ViewsSeries | None = None


PRESETS: dict[str, StabilityPreset] = {
    "tiny": StabilityPreset(("tiny", {"frames": 8, "holdout_frames": 3}),
                            ("tiny", {"steps": 4, "inpaint_steps": 0}), "tiny",
                            {"misalignment": [0, 10], "slide": [0, 0.03], "loose": [0, 0.1], "fast": [1, 2],
                             "keypoints": [0, 15], "coverage": [0, 180]},
                            ViewsSeries(("tiny", {"frames": 24, "holdout_frames": 0, "corrupt": 0.0}), "tiny", (4, 8),
                                        ("truth",))),
    "default": StabilityPreset(("default", {"frames": 64, "size": 256, "holdout_frames": 16, "detector": "none"}),
                               ("cpu", {"resolution": 128, "steps": 400, "inpaint_steps": 40, "inpaint_views": 8}),
                               "fast",
                               {"misalignment": [0, 2, 5, 10], "slide": [0, 0.006, 0.015, 0.03],
                                "loose": [0, 0.025, 0.06, 0.12], "fast": [1, 2, 4, 8],
                                "keypoints": [0, 3, 8, 15], "coverage": [0, 90, 180, 240]},
                               # MediaPipe needs the default's 512 px person; 240 frames: the dense reference
                               ViewsSeries(("default", {"holdout_frames": 0, "corrupt": 0.0}), "fast", (8, 12, 16, 24, 60))),
}
