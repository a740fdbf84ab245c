"""The trainings of ``morf bench quality``: every learned method once per seed, the RGB floor once.

Runs live in ``PROJECT/runs``: ``bench-<method>-<preset>`` for seed 0 (the name the benchmark has
always used, so earlier runs of the same configuration are reused) and
``bench-<method>-<preset>-s<seed>`` for the others; the floor (deterministic) is
``bench-rgb-<preset>``. A killed training resumes on the next call. A run that exists with
another configuration, or on other fits, is refused in one line rather than silently reused
(the floor, seconds to build, is rebuilt instead).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

FLOOR = "rgb"


def run_name(method: str, preset: str, seed: int = 0) -> str:
    base = f"bench-{method}-{preset}"
    return base if seed == 0 else f"{base}-s{seed}"


@dataclass(frozen=True)
class BenchRun:
    """One training of the benchmark.

    Fields:
        method, seed, name (the run folder under PROJECT/runs); diverged: training raised
        TrainingDiverged (no avatar; left out of the scores); train_minutes: the training loop's
        own time, all sessions; wall_minutes: this call's wall time; steps; plateau_minutes: when
        the training L1 stopped improving (:mod:`morf.train.plateau`; None for the floor or a
        short run); error: the divergence message.
    """

    method: str
    seed: int
    name: str
    diverged: bool = False
    train_minutes: float | None = None
    wall_minutes: float | None = None
    steps: int | None = None
    plateau_minutes: float | None = None
    error: str | None = None

    @property
    def is_floor(self) -> bool:
        return self.method == FLOOR

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class TrainPlan:
    """What every training shares. Fields: preset, holdout (the usable frames numbered 0, K, 2K, ...
    kept out; 0: none), steps (None: the preset's), fits (the resolved source, "fits" | "ground-truth"), vgg."""

    preset: str
    holdout: int
    steps: int | None
    fits: str
    vgg: str | None = None

    def config(self, method: str, seed: int = 0):
        from morf.train.config import preset

        overrides = {"steps": self.steps} if self.steps else {}
        return preset(self.preset, method, holdout=self.holdout, seed=seed, **overrides)


def train_runs(project, plan: TrainPlan, methods: list[str], seeds: int, model) -> list[BenchRun]:
    """Train (or resume, or reuse) every learned method with seeds 0..seeds-1, then the floor."""
    runs = []
    for method in methods:
        for seed in range(seeds):
            runs.append(_train(project, plan, method, seed, model))
    runs.append(_train(project, plan, FLOOR, 0, model))
    return runs


def _train(project, plan: TrainPlan, method: str, seed: int, model) -> BenchRun:
    from morf.errors import TrainingDiverged
    from morf.train.plateau import run_plateau
    from morf.train.project_run import train_project

    name = run_name(method, plan.preset, seed)
    cfg = plan.config(method, seed)
    restart = _check_existing(project.runs_dir / name, cfg, plan.fits)
    print(f"training {name} ({method}, seed {seed}) ...")
    t0 = time.time()
    try:
        res = train_project(project, cfg, name, fits_source=plan.fits, vgg=plan.vgg, model=model, restart=restart)
    except TrainingDiverged as e:
        print(f"{name}: diverged ({e})")
        return BenchRun(method, seed, name, diverged=True, wall_minutes=(time.time() - t0) / 60, error=str(e))
    plat = None if method == FLOOR else run_plateau(res.run_dir)
    return BenchRun(method, seed, name, train_minutes=res.train_minutes, wall_minutes=(time.time() - t0) / 60,
                    steps=res.step, plateau_minutes=None if plat is None else plat.minutes)


def _check_existing(run_dir: Path, cfg, fits: str) -> bool:
    """Whether an existing floor must be rebuilt; a learned run that differs raises InputError."""
    from morf.errors import InputError
    from morf.evaluate.runs import run_fits_source
    from morf.train.run_dir import RunDir

    run = RunDir(run_dir)
    if not run.config_path.is_file():
        return False
    old, old_fits = run.load_config(), run_fits_source(run.root)
    if cfg.method == FLOOR:
        from morf.train.floor import floor_config

        return old != floor_config(cfg, old.texture_size) or old_fits not in (fits, "auto")
    if old != cfg:
        raise InputError(f"run {run.root} exists with another configuration (other --steps, --holdout or an older "
                         "preset); move it away or use another --project / --out")
    if old_fits not in (fits, "auto"):
        raise InputError(f"run {run.root} was trained on {old_fits} fits, not {fits}; pass --fits {old_fits} or move "
                         "it away")
    return False
