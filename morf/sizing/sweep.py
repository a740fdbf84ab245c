"""The speed-against-accuracy sweep: which knobs are turned, by how much, per sweep preset.

Each :class:`SweepPoint` changes one knob of the preset's base training config (one-at-a-time
around the base, so every point's change is readable on its own); ``resolve`` turns a point into
the TrainConfig that is trained. Points that train the same config (int8 and fp32 of one model)
share one training run, named by :func:`train_key`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field

from morf.errors import InputError
from morf.train.config import TrainConfig, preset

# Renderer architectures (RendererConfig fields except in_channels, which follows the texture).
RENDERERS: dict[str, dict] = {
    "plain_b16": dict(stem=1, width=16, depth=4, max_width=64, skip_hidden=16),
    "stem2_b8": dict(stem=2, width=8, depth=4, max_width=32, skip_hidden=8),
    "stem2_b16": dict(stem=2, width=16, depth=4, max_width=64, skip_hidden=16),
    "stem2_b24": dict(stem=2, width=24, depth=4, max_width=96, skip_hidden=16),
    "stem4_b8": dict(stem=4, width=8, depth=4, max_width=32, skip_hidden=8, head_stride=2),
    "stem4_b16": dict(stem=4, width=16, depth=4, max_width=64, skip_hidden=16, head_stride=2),  # the "cpu" preset
    "stem4_b24": dict(stem=4, width=24, depth=4, max_width=96, skip_hidden=16, head_stride=2),
    "stem4_b32": dict(stem=4, width=32, depth=4, max_width=128, skip_hidden=16, head_stride=2),
    "stem4_b48": dict(stem=4, width=48, depth=4, max_width=192, skip_hidden=16, head_stride=2),
    # CI sizes (the "tiny" training preset's renderer and its neighbours)
    "tiny_b4": dict(stem=2, width=4, depth=2, max_width=256, skip_hidden=8),
    "tiny_b8": dict(stem=2, width=8, depth=2, max_width=256, skip_hidden=8),
    "tiny_b16": dict(stem=2, width=16, depth=2, max_width=256, skip_hidden=8),
}

AXES = ("base", "renderer", "texture_size", "texture_channels", "resolution", "steps", "schedule", "method",
        "precision", "seed", "auto")
# The seed axis retrains the base point with other random seeds: its spread is the noise a single
# training per point carries. Those points measure the base again, so they stay off the fronts.
NOISE_AXES = ("seed",)


@dataclass(frozen=True)
class SweepPoint:
    """One configuration of the sweep.

    Fields:
        name: unique file-safe name; axis: the knob it changes (one of :data:`AXES`);
        change: TrainConfig overrides; ``renderer`` may name an entry of :data:`RENDERERS`
            (or be a dict of RendererConfig fields); method: morf | stylepeople | anr;
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

# Synthetic scenes: SynthConfig overrides.
SCENES: dict[str, dict] = {
    "print": {},
    "plain": {"clothing": "plain"},
    "loose": {"loose": 0.1},
}


def renderer_fields(spec) -> dict:
    """RendererConfig fields (without in_channels) of a renderer name or field dict."""
    if isinstance(spec, str):
        if spec not in RENDERERS:
            raise InputError(f"unknown renderer {spec!r}; choose one of {', '.join(RENDERERS)}")
        return {"head_stride": 1, **RENDERERS[spec]}  # a name gives the whole architecture
    return {k: v for k, v in dict(spec).items() if k != "in_channels"}


def resolve(sweep: SweepPreset, point: SweepPoint, **extra) -> TrainConfig:
    """The TrainConfig a point trains: the sweep's base with the point's change (and ``extra``)."""
    name, overrides = sweep.train
    base = preset(name, point.method, **overrides)
    change = {**point.change, **extra}
    channels = int(change.pop("texture_channels", base.texture_channels))
    rfields = renderer_fields(change.pop("renderer")) if "renderer" in change else {
        k: v for k, v in dataclasses.asdict(base.renderer).items() if k != "in_channels"}
    renderer = dataclasses.replace(base.renderer, in_channels=channels, **rfields)  # keeps rgb_skip & co.
    return base.replace(texture_channels=channels, renderer=renderer, **change)


def train_key(cfg: TrainConfig) -> str:
    """A short stable name for a training config (the run folder is ``pareto-<key>``).

    The decay fields, the weight average, the residual penalty, the warp fade and a full-resolution
    renderer head are left out while off (they change nothing then), so
    runs made before they existed keep their names."""
    d = cfg.to_dict()
    if d["lr_decay_start"] >= 1.0:
        del d["lr_decay_start"], d["lr_decay_floor"]
    if d["ema_decay"] == 0.0:
        del d["ema_decay"]
    if d["w_residual"] == 0.0:
        del d["w_residual"]
    if d["warp_fade_start"] >= 1.0 and d["warp_fade_end"] >= 1.0:
        del d["warp_fade_start"], d["warp_fade_end"]
    if d["renderer"].get("head_stride") == 1:
        del d["renderer"]["head_stride"]
    return hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:10]


def select(sweep: SweepPreset, axes: list[str] | None, names: list[str] | None = None) -> list[SweepPoint]:
    """The sweep's points on the given axes (all when None), or only those named in ``names``;
    the base point is always kept (every other point is read against it)."""
    bad = [a for a in axes or [] if a not in AXES]
    if bad:
        raise InputError(f"unknown sweep axes {bad}; choose from {', '.join(AXES)}")
    known = [p.name for p in sweep.points]
    unknown = [n for n in names or [] if n not in known]
    if unknown:
        raise InputError(f"unknown sweep points {unknown}; the {sweep.name} sweep has {', '.join(known)}")
    return [p for p in sweep.points if p.axis == "base"
            or ((not axes or p.axis in axes) and (not names or p.name in names))]
