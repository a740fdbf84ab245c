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
    # train config fields set over the preset's (``morf train --set FIELD=VALUE``)
    train_set: tuple[tuple[str, object], ...] = ()

    def train_set_args(self) -> tuple[str, ...]:
        """``train_set`` as ``morf train`` options."""
        import json

        return tuple(a for k, v in self.train_set for a in ("--set", f"{k}={json.dumps(v)}"))


# The colour channels projected from the capture's 512 px frames (not the 256 px training frames),
# weighted towards the frames that face a texel and first aligned to one another by optical flow:
# the print on the demo's shirt reads "NEURAL" at 640 px instead of a blur after "EURAL", and the
# face has its eyes, for the same training time (docs/avatar.md, "The demo's face and print").
SHARP_COLOUR = (("colour_from_zoom", True), ("colour_facing_power", 8.0), ("colour_align_passes", 2))


PRESETS: dict[str, DemoPreset] = {
    # Seconds: what CI runs.
    "tiny": DemoPreset("tiny", "fast", "tiny", None, 128, 8),
    # Under ten minutes on 2 CPU cores: a default-size capture, a shortened cpu-preset training (the
    # colour starts from the projected frames, so a few hundred steps already look like the person;
    # the stem x4 renderer affords 1000 of the preset's 1500 in about the time 600 took at stem x2).
    "quick": DemoPreset("default", "default", "cpu", 1000, 640, 240, SHARP_COLOUR),
    # The cpu preset trained to its plateau (tens of minutes).
    "full": DemoPreset("default", "default", "cpu", None, 640, 0, SHARP_COLOUR),
}
