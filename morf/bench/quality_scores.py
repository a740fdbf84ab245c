"""Per-method scores of one evaluation block of ``morf bench quality``, over the training seeds.

A block is one target of :func:`morf.evaluate.project_eval.evaluate_project` (the synthetic
hold-out sequence, or the capture frames every run kept out of training). Each method's entry
holds the mean of every metric over its seeds, the per-seed values and the spread (max - min) of
person PSNR and SSIM and of the head's shift-tolerant SSIM; the floor has one run, so its spread
is None, as is any method's with fewer than two scored seeds. Runs that diverged are left out of the
means and counted.

Configurations are compared on the detail scores (:mod:`morf.evaluate.detail`) as well as on PSNR:
person PSNR alone prefers a blurred render to a sharp one a few pixels off. ``DETAIL_METRICS``
are the region scores at native size (person, head, hands: SSIM at the best shift within +-4 px,
GMSD, high-frequency ratio render / real); None where ``morf eval`` scored no such region.
"""

from __future__ import annotations

from dataclasses import dataclass

from morf.bench.quality_runs import BenchRun
from morf.evaluate.results import EvalResult

# the LPIPS means are None when morf eval had no LPIPS weights
DETAIL_METRICS = tuple(f"{g}_{s}" for g in ("person", "head", "hands")
                       for s in ("ssim_shift", "gmsd", "hf_ratio", "hf_ratio_inside"))
METRICS = ("psnr", "psnr_person", "ssim", "ssim_person", "temporal", "lpips", "lpips_person") + DETAIL_METRICS
SPREAD_KEYS = ("psnr_person", "ssim_person", "head_ssim_shift")


@dataclass(frozen=True)
class MethodScores:
    """Fields: method; mean: {metric: mean over the scored seeds}; seeds: one dict per scored seed
    ({"seed", "run", metric: value}); spread: {psnr_person, ssim_person, head_ssim_shift: max - min,
    None under two seeds}; diverged: trainings that diverged (not scored)."""

    method: str
    mean: dict
    seeds: tuple[dict, ...]
    spread: dict
    diverged: int = 0

    def to_dict(self) -> dict:
        return {"method": self.method, "mean": dict(self.mean), "seeds": [dict(s) for s in self.seeds],
                "spread": dict(self.spread), "diverged": self.diverged}


@dataclass(frozen=True)
class BlockScores:
    """Fields: key (the eval target: "novel-poses", "holdout-k<K>"); title; frames: how many
    frames it scores; sheet, slices: the image files (in the output folder); methods: method ->
    MethodScores, the floor last; heads: the enlarged head crops image (None: no head scored)."""

    key: str
    title: str
    frames: int
    sheet: str
    slices: str
    methods: dict
    heads: str | None = None

    def to_dict(self) -> dict:
        return {"key": self.key, "title": self.title, "frames": self.frames, "sheet": self.sheet,
                "slices": self.slices, "heads": self.heads,
                "methods": {m: s.to_dict() for m, s in self.methods.items()}}


def _mean(values: list) -> float | None:
    vals = [v for v in values if v is not None]
    return sum(vals) / len(vals) if vals else None


def _spread(values: list) -> float | None:
    vals = [v for v in values if v is not None]
    return max(vals) - min(vals) if len(vals) > 1 else None


def method_scores(method: str, runs: list[BenchRun], eval_result: EvalResult, key: str) -> MethodScores:
    """The scores of one method's runs on target ``key`` of an evaluation."""
    seeds = []
    for r in runs:
        m = None if r.diverged else eval_result.scores(r.name, key)
        if m is not None:
            seeds.append({"seed": r.seed, "run": r.name, **{k: m.metric(k) for k in METRICS}})
    return MethodScores(method, {k: _mean([s[k] for s in seeds]) for k in METRICS}, tuple(seeds),
                        {k: _spread([s[k] for s in seeds]) for k in SPREAD_KEYS},
                        sum(1 for r in runs if r.diverged))


def block_scores(eval_result: EvalResult, key: str, runs: list[BenchRun]) -> BlockScores:
    """Every method's scores on target ``key``, in the order the runs were trained (floor last)."""
    target = eval_result.targets[key]
    methods = list(dict.fromkeys(r.method for r in runs))
    return BlockScores(key, target.title, len(target.frame_ids), target.sheet, target.slices,
                       {m: method_scores(m, [r for r in runs if r.method == m], eval_result, key) for m in methods},
                       target.heads)
