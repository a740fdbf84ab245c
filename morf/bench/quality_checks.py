"""The targets ``morf bench quality`` checks, per evaluation block, on the means over the seeds.

* morf against the no-learning floor: ``morf_minus_floor_psnr_person_db`` >= 3 dB and
  ``morf_minus_floor_ssim_person`` >= 0.15 (person PSNR / SSIM, morf's mean minus the floor);
* morf's reproducibility: ``morf_seed_spread_db`` (max - min person PSNR over its seeds) <= 1 dB;
  not measured (None) with one seed;
* morf against stylepeople (the same network without the warp fields): at about equal quality
  (``psnr_delta_vs_stylepeople_db`` >= -0.5 dB; ``ssim_delta_vs_stylepeople`` reported) it
  flickers at least 10 % less (``temporal_gain_vs_stylepeople`` = 1 - morf / stylepeople >= 0.10);
* detail where people look (scores at native size, :mod:`morf.evaluate.detail`): the head's
  shift-tolerant SSIM at least the floor's (``morf_minus_floor_head_ssim_shift`` >= 0; PSNR alone
  would choose blur), and the head's high-frequency ratio render / real inside the real person
  ``morf_head_hf_ratio_inside`` >= 0.7 (under 1 is blur; the box's ratio ``morf_head_hf_ratio``,
  which a small head's matte edge dominates, is reported beside it).

A value is None when a method it needs was not run or has no scored run; its target's ``met`` is
then None too.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass

from morf.bench.quality_scores import BlockScores


@dataclass(frozen=True)
class Target:
    """``value <op> bound``, e.g. ``morf_seed_spread_db <= 1``."""

    name: str
    op: str  # ">=" | "<="
    bound: float

    def met(self, value: float | None) -> bool | None:
        if value is None:
            return None
        return bool({">=": operator.ge, "<=": operator.le}[self.op](value, self.bound))

    def describe(self) -> str:
        return f"{self.name} {self.op} {self.bound:g}"


TARGETS = (
    Target("morf_minus_floor_psnr_person_db", ">=", 3.0),
    Target("morf_minus_floor_ssim_person", ">=", 0.15),
    Target("morf_seed_spread_db", "<=", 1.0),
    Target("psnr_delta_vs_stylepeople_db", ">=", -0.5),
    Target("temporal_gain_vs_stylepeople", ">=", 0.10),
    Target("morf_minus_floor_head_ssim_shift", ">=", 0.0),
    Target("morf_head_hf_ratio_inside", ">=", 0.7),
)
PLATEAU = Target("morf_plateau_minutes", "<=", 30.0)  # mean over morf's seeds, from the training logs


@dataclass(frozen=True)
class Checks:
    """Fields: values: {name: measured value or None}; targets: the targets checked on them."""

    values: dict
    targets: tuple[Target, ...]

    @property
    def met(self) -> dict:
        return {t.name: t.met(self.values.get(t.name)) for t in self.targets}

    def to_dict(self) -> dict:
        met = self.met
        return {**self.values, "targets": {t.name: {"want": f"{t.op} {t.bound:g}", "met": met[t.name]}
                                           for t in self.targets}}


def _diff(a, b):
    return None if a is None or b is None else a - b


def block_checks(block: BlockScores, floor: str) -> Checks:
    """The targets on one block; ``floor`` is the floor's method name."""
    mean = {m: s.mean for m, s in block.methods.items()}
    empty: dict = {}
    morf, sp, fl = mean.get("morf", empty), mean.get("stylepeople", empty), mean.get(floor, empty)
    t_m, t_s = morf.get("temporal"), sp.get("temporal")
    values = {
        "morf_minus_floor_psnr_person_db": _diff(morf.get("psnr_person"), fl.get("psnr_person")),
        "morf_minus_floor_ssim_person": _diff(morf.get("ssim_person"), fl.get("ssim_person")),
        "morf_seed_spread_db": block.methods["morf"].spread["psnr_person"] if "morf" in block.methods else None,
        "psnr_delta_vs_stylepeople_db": _diff(morf.get("psnr"), sp.get("psnr")),
        "ssim_delta_vs_stylepeople": _diff(morf.get("ssim"), sp.get("ssim")),
        "temporal_gain_vs_stylepeople": 1 - t_m / t_s if t_m is not None and t_s else None,
        "morf_minus_floor_head_ssim_shift": _diff(morf.get("head_ssim_shift"), fl.get("head_ssim_shift")),
        "morf_head_hf_ratio": morf.get("head_hf_ratio"),
        "morf_head_hf_ratio_inside": morf.get("head_hf_ratio_inside"),
    }
    return Checks(values, TARGETS)


def training_checks(plateau_minutes: float | None) -> Checks:
    """The training-time target: morf's mean plateau (None when it was not run or too short)."""
    return Checks({PLATEAU.name: plateau_minutes}, (PLATEAU,))
