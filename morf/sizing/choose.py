"""``--preset auto``: pick the smallest neural texture, channel count and renderer a capture needs.

The rule (thresholds in :class:`SizingRule`; the measurements behind each one are in
docs/benchmarks.md, "Automatic size choice"):

1. Texture resolution from texel density: a person ``h`` pixels tall in the training images sees
   ``0.82 * S / h`` texels per pixel at atlas size ``S`` (Anny's atlas spans about 0.82 sides per
   body height). Patterned clothing gets about one texel per pixel, plain clothing and loose
   garments (much of which lies off the body surface) less; ``S`` is the smallest power of two
   that reaches the density, within the detail level's bounds.
2. Channels (never above the base preset): 16 for plain clothing that follows the body, 8 for
   patterned clothing and loose garments.
3. Renderer: the preset's; the rule can step along the preset's ladder for plain or loose
   clothing, and the calibration set both steps to 0.

Frame count and motion range do not change the sizes (they decide what can be learned at all);
they are reported so a user sees why a capture may disappoint. Over three seeds per point the
rule's choices came within 0.5 dB of the best sweep point on three captures it was not calibrated
on; the smaller textures and 8 channels are its bets.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from morf.sizing.features import ATLAS_UNITS_PER_METRE, BODY_HEIGHT_M, CaptureFeatures
from morf.train.config import TrainConfig, preset

# Renderer ladders (smallest first) per base preset; the middle one is the preset's own.
LADDERS: dict[str, tuple[str, ...]] = {
    "tiny": ("tiny_b4", "tiny_b8", "tiny_b16"),
    "cpu": ("stem4_b8", "stem4_b16", "stem4_b24"),
}
CROP_MARGIN = 1.16  # training crop side / person height (morf.train.data.person_square, 8 % margins)


@dataclass(frozen=True)
class SizingRule:
    """Thresholds of the automatic size choice (the measurements behind each value:
    docs/benchmarks.md, "Figures behind SizingRule")."""

    # fine-band colour RMS at the training scale (CaptureFeatures.detail)
    detail_high: float = 0.04  # at or above this: detailed clothing
    detail_low: float = 0.023  # below this: plain clothing (between the busiest plain and the calmest print)
    density_high: float = 0.9  # texels per training pixel for detailed clothing
    density_mid: float = 0.9  # ... for medium detail (sized like detailed: a striped print lost 2.6 dB at half)
    density_low: float = 0.22  # ... for plain clothing
    excess_high: float = 0.2  # share of the mask outside the fitted body that counts as loose garments
    density_loose: float = 0.22  # loose garments: painted from the silhouette more than from texels
    min_texture_loose: int = 64
    channels_by_detail: tuple[int, int, int] = (16, 8, 8)  # tight clothing: plain, medium, detailed
    channels_loose: int = 8
    plain_renderer_step: int = 0  # ladder steps for plain, tight clothing (-1 = one smaller)
    loose_renderer_step: int = 0  # ... for loose garments
    # smallest texture per detail level (plain, medium, detailed): below 128^2 the atlas islands are a
    # few texels wide and bleed into each other, so only plain clothing (and loose garments) go to 64^2
    min_texture_by_detail: tuple[int, int, int] = (64, 128, 128)
    max_texture: int = 1024
    quality_margin_db: float = 0.5  # "near the best": within this much person-PSNR of the best on the sweep
    fps_margin_frac: float = 0.2  # ... and within this share of its fps (this VM's fps noise for equal graphs)


def _pow2_at_least(x: float, lo: int, hi: int) -> int:
    s = lo
    while s < x and s < hi:
        s *= 2
    return s


def choose_from_features(f: CaptureFeatures, base: TrainConfig, base_preset: str,
                         rule: SizingRule = SizingRule()) -> tuple[TrainConfig, list[str]]:
    """The rule on measured features (pure; see the module docstring)."""
    from morf.sizing.sweep import renderer_fields

    reasons = []
    h_train = base.resolution / CROP_MARGIN
    h = min(f.person_height_px, h_train)
    level = "high" if f.detail >= rule.detail_high else "low" if f.detail < rule.detail_low else "mid"
    li = ("low", "mid", "high").index(level)  # index into the per-level tuples of the rule
    excess = f.silhouette_excess
    loose = excess is not None and excess >= rule.excess_high
    density, floor = ((rule.density_loose, rule.min_texture_loose) if loose else
                      ((rule.density_low, rule.density_mid, rule.density_high)[li], rule.min_texture_by_detail[li]))
    texels_per_side = ATLAS_UNITS_PER_METRE * BODY_HEIGHT_M  # atlas sides per body height
    size = _pow2_at_least(density * h / texels_per_side, floor, rule.max_texture)
    reasons.append(f"person {f.person_height_px:.0f} px tall in the capture, about {h_train:.0f} px at the "
                   f"{base.resolution} px training resolution -> {h:.0f} px to cover")
    reasons.append(f"clothing detail {f.detail:.3f} (fine-band colour RMS at the training scale; "
                   f"{rule.detail_low} / {rule.detail_high} split plain / medium / detailed): {level}")
    if loose:
        reasons.append(f"{excess:.0%} of the person lies outside the fitted body (>= {rule.excess_high:.0%}: "
                       f"loose garments, painted by the renderer from the silhouette more than from texels) -> "
                       f"{density} texels per pixel -> texture {size}x{size}")
    else:
        reasons.append(f"{level} detail -> {density} texels per pixel -> texture {size}x{size}")
    channels = min(rule.channels_loose if loose else rule.channels_by_detail[li], base.texture_channels)
    reasons.append(f"{'loose garments' if loose else level + ' detail'} -> {channels} texture channels "
                   f"(base preset: {base.texture_channels})")
    ladder = LADDERS.get(base_preset)
    rfields = {k: v for k, v in dataclasses.asdict(base.renderer).items() if k != "in_channels"}
    if ladder:
        mid = 1  # the middle of a ladder is the preset's own renderer
        if loose:
            step = rule.loose_renderer_step
            why = "loose garments"
        elif level == "low":
            step = rule.plain_renderer_step
            why = "plain clothing that follows the body"
        else:
            step = 0
            why = "neither plain nor loose" + (f" ({excess:.0%} of the person outside the fitted body)"
                                               if excess is not None else "")
        name = ladder[min(max(mid + step, 0), len(ladder) - 1)]
        rfields = renderer_fields(name)
        reasons.append(f"renderer {name}: {why}" + ("" if step else " (the preset's renderer: other sizes did not "
                                                                    "pay on the calibration sweep)"))
    else:
        reasons.append(f"renderer of the {base_preset!r} preset kept (no smaller/larger ladder for it)")
    if f.frames < 60:
        reasons.append(f"only {f.frames} training frames: expect less detail on novel poses (sizes unchanged)")
    if f.yaw_coverage_deg is not None and f.yaw_coverage_deg < 270:
        reasons.append(f"the fits cover {f.yaw_coverage_deg:.0f} degrees of the turn: unseen sides come from "
                       "inpainting (sizes unchanged)")
    cfg = base.replace(preset="auto", texture_size=size, texture_channels=channels,
                       renderer=dataclasses.replace(base.renderer, in_channels=channels, **rfields))
    return cfg, reasons


def choose_train_config(project, base_preset: str = "cpu", method: str = "morf", model=None,
                        rule: SizingRule = SizingRule(), **overrides) -> tuple[TrainConfig, list[str]]:
    """Measure ``project`` (a CaptureProject) and size its avatar.

    Args:
        base_preset: the training preset whose resolution, steps and losses are kept.
        method: morf | stylepeople | anr. model: a loaded body model (for the silhouette excess;
            without it that feature is skipped). overrides: TrainConfig fields applied to the base first.
    Returns:
        (the chosen TrainConfig with ``preset="auto"``, human-readable reasons for the run log).
    """
    from morf.sizing.features import capture_features

    base = preset(base_preset, method, **overrides)
    f = capture_features(project, model, person_px=base.resolution / CROP_MARGIN)
    cfg, reasons = choose_from_features(f, base, base_preset, rule)
    return cfg, [f"automatic size from the capture (base preset {base_preset!r})"] + reasons
