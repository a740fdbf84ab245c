"""``morf demo``'s presets: how big a run the demo makes, as stage presets plus overrides.

Plain data (no torch): :mod:`morf.presets` registers the table as stage ``demo`` and
:mod:`morf.cli.demo` runs it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class DemoPreset:
    synth: str  # morf synth preset
    fit: str  # morf fit preset
    train: str  # morf train preset
    train_steps: int | None  # override of the preset's steps (None: the preset's own)
    size: int  # output video size in pixels
    max_frames: int  # frames of the motion to render (0: all)


PRESETS: dict[str, DemoPreset] = {
    # Seconds: what CI runs.
    "tiny": DemoPreset("tiny", "fast", "tiny", None, 128, 8),
    # Under ten minutes on 2 CPU cores: a default-size capture, a shortened cpu-preset training (the
    # colour starts from the projected frames, so a few hundred steps already look like the person;
    # the stem x4 renderer affords 1000 of the preset's 1500 in about the time 600 took at stem x2).
    "quick": DemoPreset("default", "default", "cpu", 1000, 640, 240),
    # The cpu preset trained to its plateau (tens of minutes).
    "full": DemoPreset("default", "default", "cpu", None, 640, 0),
}
