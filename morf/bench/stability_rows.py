"""The rows of ``morf bench stability``: one training of a (series, level, method, seed), as saved in
``OUT/points/``, and one level's repeats combined; a level's row in ``stability.json`` is the
first when every point is trained once, the second with ``--repeats``."""

from __future__ import annotations

from dataclasses import dataclass

from morf.bench.train_eval import TrainEvaluation


@dataclass(frozen=True)
class StabilityPoint:
    """One training of a stress series (``OUT/points/<series>-<level index>-<method>[-seed<r>].json``).

    Fields:
        series; level: the nuisance's level, as the preset gives it; method; seed: the training's
        seed (0 in files saved before seeds were kept, which were trained with it);
        evaluation: the training scored on the hold-out.
    """

    series: str
    level: object
    method: str
    seed: int
    evaluation: TrainEvaluation

    @property
    def diverged(self) -> bool:
        return self.evaluation.diverged

    @property
    def psnr_person(self) -> float | None:
        return self.evaluation.psnr_person

    def to_dict(self) -> dict:
        return {"series": self.series, "level": self.level, "method": self.method, "seed": self.seed,
                **self.evaluation.to_dict()}

    @staticmethod
    def from_dict(d: dict) -> StabilityPoint:
        return StabilityPoint(d["series"], d["level"], d["method"], d.get("seed", 0), TrainEvaluation.from_dict(d))


@dataclass(frozen=True)
class LevelRepeats:
    """One (series, level, method) trained with several seeds (:func:`morf.bench.stability.combine_repeats`).

    Fields:
        series, level, method, seed: the first repeat's; params: the renderer's parameters;
        diverged: some repeat diverged; psnr, ssim, psnr_person, ssim_person, temporal,
            train_minutes: means over the repeats that did not diverge (None when all did);
        repeats: trainings; diverged_runs: those that diverged;
        psnr_person_min, psnr_person_max, psnr_person_std: over the repeats that did not diverge
            (the standard deviation needs two of them; None otherwise);
        runs: each repeat's run folder (None for a training that raised);
        background, frames, eval_resolution: the first repeat's hold-out backdrop and frame count
            and scoring size (None when it raised; then left out of :meth:`to_dict`).
    """

    series: str
    level: object
    method: str
    seed: int
    params: int
    diverged: bool
    psnr: float | None
    ssim: float | None
    psnr_person: float | None
    ssim_person: float | None
    temporal: float | None
    train_minutes: float | None
    repeats: int
    diverged_runs: int
    psnr_person_min: float | None
    psnr_person_max: float | None
    psnr_person_std: float | None
    runs: tuple[str | None, ...]
    background: tuple[float, ...] | None = None
    frames: int | None = None
    eval_resolution: int | None = None

    def to_dict(self) -> dict:
        d = {"series": self.series, "level": self.level, "method": self.method, "seed": self.seed}
        if self.background is not None:
            d.update(background=list(self.background), frames=self.frames)
        d.update(diverged=self.diverged, params=self.params)
        if self.eval_resolution is not None:
            d["eval_resolution"] = self.eval_resolution
        d.update(psnr=self.psnr, ssim=self.ssim, psnr_person=self.psnr_person, ssim_person=self.ssim_person,
                 temporal=self.temporal, train_minutes=self.train_minutes, repeats=self.repeats,
                 diverged_runs=self.diverged_runs, psnr_person_min=self.psnr_person_min,
                 psnr_person_max=self.psnr_person_max, psnr_person_std=self.psnr_person_std, runs=list(self.runs))
        return d
