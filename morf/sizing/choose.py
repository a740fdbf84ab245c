"""``--preset auto``: pick the smallest neural texture, channel count and renderer a capture needs.

The rule (thresholds in :class:`SizingRule`, calibration in docs/benchmarks.md):

1. Texture resolution from texel density. Anny's atlas spans about 0.82 atlas sides per body
   height, so a person ``h`` pixels tall in the training images sees ``0.82 * S / h`` texels per
   pixel at atlas size ``S``. ``h`` is the person's height at the training resolution (the crop
   is about 1.16 person heights), capped by the height in the capture (upsampling adds nothing).
   Patterned clothing (medium or high detail: the fine-band colour energy at the training scale,
   ``CaptureFeatures.detail``) gets about one texel per pixel: at half a texel per pixel (128^2)
   the default-size print scored 0.05 dB over its base in one run and 0.95 dB under it in another,
   64^2 cost it 1.2 dB, and a striped print of medium detail lost 2.6 dB at 128^2. Plain
   clothing is band-limited and is given less, and so are loose garments (at least 20 % of the
   person mask outside the fitted body's silhouette): much of such a garment lies off the body
   surface, where the renderer paints it from the silhouette. S =
   the smallest power of two >= density * h / 0.82, in [64, 1024] for plain clothing and loose
   garments and [128, 1024] otherwise.
2. Channels (never above the base preset): 16 for plain clothing that follows the body, 8 for
   patterned clothing and loose garments. At default size 8 channels cost plain clothing 0.7 dB,
   and with a 128^2 texture they cost plain and print 1.3-1.5 dB; at 256^2 they gained three
   print captures 0.1-1.2 dB and cost a fourth 1.4 dB, and the loose scene kept its quality at
   64^2 x 8.
3. Renderer: the preset's. The rule can step down the preset's ladder for plain, tight clothing
   and up when much of the person lies outside the fitted body (``SizingRule`` steps), but at
   default size (docs/benchmarks.md) the ladder's smaller renderer cost 1.0-3.6 dB on plain, print
   and loose scenes and the larger one lost 1.5 dB on the loose scene, so both steps are 0 (measured
   on the stem x2 ladder the ``cpu`` preset used before its stem x4 base 24 renderer).

Frame count and motion range do not change the sizes (they decide what can be learned at all);
they are reported so a user sees why a capture may disappoint.

How far to trust it: on three captures it was not calibrated on (docs/benchmarks.md, third and
fourth rounds) its single-training verdicts came out 0.7-2.8 dB under the best point; over three
seeds per point all three choices (plain 64^2 x 16, print 256^2 x 8, loose 64^2 x 8) came within
the 0.5 dB margin of the best point at comparable speed (0.11, -0.01 and 0.41 dB under). The
base's seed noise at default size ranged from 0.3 to 3.0 dB (std over three seeds) between
captures, so those gaps' standard errors (0.4-1.8 dB) leave none of the verdicts beyond it. The
preset's renderer and 256^2 for patterned clothing held throughout; the smaller textures and 8
channels are the rule's bets.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from morf.sizing.features import ATLAS_UNITS_PER_METRE, BODY_HEIGHT_M, CaptureFeatures
from morf.train.config import TrainConfig, preset

# Renderer ladders (smallest first) per base preset; the middle one is the preset's own.
LADDERS: dict[str, tuple[str, ...]] = {
    "tiny": ("tiny_b4", "tiny_b8", "tiny_b16"),
    "cpu": ("stem4_b16", "stem4_b24", "stem4_b32"),
}
CROP_MARGIN = 1.16  # training crop side / person height (morf.train.data.person_square, 8 % margins)


@dataclass(frozen=True)
class SizingRule:
    """Thresholds of the automatic size choice."""

    # fine-band colour RMS at the training scale (CaptureFeatures.detail). Default-size captures measured:
    # plain clothing 0.017 and 0.009, prints 0.057 and 0.030 (a colour stripe), loose garments 0.052 and 0.028
    detail_high: float = 0.04  # at or above this: detailed clothing
    detail_low: float = 0.023  # below this: plain clothing (between the busiest plain and the calmest print)
    # texels per training pixel for detailed clothing: on the default-size print scene (221 px of
    # person at 256 px) 0.95 texels per pixel (256^2) held its quality in two runs, 0.47 (128^2) in one
    # of two (+0.05 and -0.95 dB against the base), 0.24 (64^2) lost 1.2 dB
    density_high: float = 0.9
    # ... for medium detail: the striped print (0.030) lost 2.6 dB at 128^2 (0.47 texels per pixel)
    # against its base at 256^2, and 3.8 dB against 256^2 x 8, so medium detail is sized like detailed
    density_mid: float = 0.9
    density_low: float = 0.22  # ... for plain clothing (64^2 held its quality at default size)
    excess_high: float = 0.2  # share of the mask outside the fitted body that counts as loose garments
    # loose garments: texels per pixel and smallest texture. Much of the garment lies off the body
    # surface, where the renderer paints it from the silhouette, not from texels: on the default-size
    # loose scene 64^2 (0.24 texels per pixel) was its best point (19.16 dB against 18.88 at 256^2)
    density_loose: float = 0.22
    min_texture_loose: int = 64
    # channels for tight clothing at each detail level (plain, medium, detailed) and for loose garments.
    # At default size 8 channels cost plain clothing 0.7 dB (22.33 against 23.00 dB) and with 128^2
    # textures plain 1.5 dB and print 1.3 dB; at 256^2 the print lost nothing (+0.2, +0.1 dB in two
    # runs), and 64^2 x 8 on the loose scene scored 1.2 dB over its base (256^2 x 16); the striped
    # print (medium) scored 25.05 dB at 256^2 x 8 against 23.87 at 256^2 x 16, a checked one (medium)
    # 22.23 against 23.65
    channels_by_detail: tuple[int, int, int] = (16, 8, 8)
    # loose garments at 64^2: 8 channels against 16 scored +0.6 dB on one loose capture and -0.7 dB on
    # another (single trainings; the means of the two agree within 0.1 dB)
    channels_loose: int = 8
    plain_renderer_step: int = 0  # ladder steps for plain, tight clothing (-1 = one smaller: b8 cost 3.6 dB)
    loose_renderer_step: int = 0  # ... for loose garments (+1 = b24 cost 1.5 dB, 38 % slower; -1 = b8 cost 1.0 dB)
    # smallest texture per detail level (plain, medium, detailed): below 128^2 the atlas islands are a
    # few texels wide and bleed into each other; on the quick sweep 64^2 cost 1.5-6.4 dB on all three
    # scenes and at default size 1.2 dB on the print, so only plain clothing may go to 64^2 (and loose
    # garments, min_texture_loose; see docs/benchmarks.md for their default-size checks)
    min_texture_by_detail: tuple[int, int, int] = (64, 128, 128)
    max_texture: int = 1024
    quality_margin_db: float = 0.5  # "near the best": within this much person-PSNR of the best on the sweep
    # ... and within this share of its fps: one sweep measured the same model at 25.3 and 25.8 fps
    # and graphs of equal cost at 20.6-27.2 fps (20 frames each on a shared VM)
    fps_margin_frac: float = 0.2


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
