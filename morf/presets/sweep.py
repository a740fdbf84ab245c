"""The speed-against-accuracy sweep's presets (``morf bench pareto``, ``--auto-check``): the capture
to make, the base training config and the points, each changing one knob of the base.

Plain data (no torch): :mod:`morf.presets` registers the table as stage ``sweep``;
:mod:`morf.sizing.sweep` turns a point into the TrainConfig it trains and names the knobs
(``AXES``) and renderer sizes (``RENDERERS``) the points refer to.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class SweepPoint:
    """One configuration of the sweep.

    Fields:
        name: unique file-safe name; axis: the knob it changes (one of :data:`morf.sizing.sweep.AXES`);
        change: TrainConfig overrides; ``renderer`` may name an entry of
            :data:`morf.sizing.sweep.RENDERERS` (or be a dict of RendererConfig fields);
            method: morf | stylepeople | anr;
        precision: int8 | fp32, the renderer the fps is measured with.
    """

    name: str
    axis: str
    change: dict = field(default_factory=dict)
    method: str = "morf"
    precision: str = "int8"


@dataclass(frozen=True)
class SweepPreset:
    """A sweep: the capture to make, the base training config and the points.

    Fields:
        synth: (synth preset name, overrides) of the capture made when none is given;
        train: (training preset name, overrides) of the base config;
        fps_size / fps_frames: playback speed is measured at fps_size^2 over that many frames;
        points: the configurations, base first.
    """

    name: str
    synth: tuple[str, dict]
    train: tuple[str, dict]
    fps_size: int
    fps_frames: int
    points: tuple[SweepPoint, ...]


def _axis_points(renderers, tex_sizes, channels, resolutions, steps, seeds=(1, 2)) -> tuple[SweepPoint, ...]:
    pts = [SweepPoint("base", "base")]
    pts += [SweepPoint(f"renderer-{r}", "renderer", {"renderer": r}) for r in renderers]
    pts += [SweepPoint(f"texture-{s}", "texture_size", {"texture_size": s}) for s in tex_sizes]
    pts += [SweepPoint(f"channels-{c}", "texture_channels", {"texture_channels": c}) for c in channels]
    pts += [SweepPoint(f"resolution-{r}", "resolution", {"resolution": r}) for r in resolutions]
    pts += [SweepPoint(f"steps-{s}", "steps", {"steps": s}) for s in steps]
    # Both sides of each schedule choice: a point equal to the base config trains once (same run).
    pts += [SweepPoint("lr-constant", "schedule", {"lr_decay_start": 1.0}),  # constant learning rates
            SweepPoint("lr-decay-half", "schedule", {"lr_decay_start": 0.5}),  # cosine decay over the second half
            SweepPoint("lr-cosine-all", "schedule", {"lr_decay_start": 0.0}),  # ... over the whole run
            SweepPoint("no-ema", "schedule", {"ema_decay": 0.0}),  # the avatar from the last step's weights
            SweepPoint("ema", "schedule", {"ema_decay": 0.998})]  # the avatar from averaged weights
    pts += [SweepPoint("stylepeople", "method", method="stylepeople"),
            SweepPoint("fp32", "precision", precision="fp32")]
    pts += [SweepPoint(f"seed-{s}", "seed", {"seed": s}) for s in seeds]
    return tuple(pts)


PRESETS: dict[str, SweepPreset] = {
    # CI: seconds. Five tiny trainings; fps measured at 128 px.
    "tiny": SweepPreset(
        "tiny", ("tiny", {"frames": 8, "holdout_frames": 3}),
        ("tiny", {"steps": 6, "inpaint_steps": 2, "inpaint_views": 2}), 128, 8,
        (SweepPoint("base", "base"), SweepPoint("renderer-tiny_b16", "renderer", {"renderer": "tiny_b16"}),
         SweepPoint("texture-32", "texture_size", {"texture_size": 32}),
         SweepPoint("stylepeople", "method", method="stylepeople"), SweepPoint("fp32", "precision", precision="fp32"),
         SweepPoint("seed-1", "seed", {"seed": 1}))),
    # By hand, about a minute a point on 2 quiet cores: a 32-frame capture at 192 px, 600 steps at
    # 128 px (100 steps gave person PSNRs of 9 dB: no quality signal).
    "quick": SweepPreset(
        "quick", ("default", {"frames": 32, "size": 192, "holdout_frames": 8, "detector": "none"}),
        ("cpu", {"resolution": 128, "batch_size": 2, "steps": 600, "inpaint_steps": 20, "inpaint_views": 4}), 640, 60,
        _axis_points(("stem2_b8", "stem2_b24", "stem4_b24"), (128, 512), (4, 8), (64, 192), (200, 1500),
                     seeds=(1, 2, 3, 4))),
    # By hand, many hours on 2 cores: the full synthetic capture and the "cpu" training preset.
    "default": SweepPreset(
        "default", ("default", {"detector": "none"}), ("cpu", {}), 640, 60,
        _axis_points(("stem2_b8", "stem2_b24", "stem4_b16", "stem4_b24", "stem4_b32", "stem4_b48", "plain_b16"),
                     (64, 128, 512, 1024), (4, 8),
                     (128, 384), (1000, 6000))),
}
