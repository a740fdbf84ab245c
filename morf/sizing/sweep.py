"""The speed-against-accuracy sweep: the knobs it turns and the training config of each point.

The sweep presets (which knobs are turned, by how much) are stage ``sweep`` of :mod:`morf.presets`,
defined with :class:`SweepPoint` and :class:`SweepPreset` in ``morf/presets/sweep.py``. Each point
changes one knob of the preset's base training config (one-at-a-time around the base, so every
point's change is readable on its own); ``resolve`` turns a point into the TrainConfig that is
trained. Points that train the same config (int8 and fp32 of one model) share one training run,
named by :func:`train_key`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json

from morf.errors import InputError
from morf.presets.sweep import SweepPoint, SweepPreset
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
