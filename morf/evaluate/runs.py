"""Which training runs ``morf eval`` scores: the finished runs of a project, the fits each one was
trained on, and the RGB floor that goes with each hold-out setting."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from morf.errors import MorfError, ProjectError
from morf.train.config import TrainConfig
from morf.train.run_dir import RunDir
from morf.train.run_files import AVATAR_FILE, RunFiles, finished_run_dirs, run_path


@dataclass(frozen=True)
class RunInfo:
    """A finished run.

    Fields:
        name: folder name under PROJECT/runs; root: the folder; config: its TrainConfig;
        fits_source: the fits it was trained on ("fits" | "ground-truth", from train.log;
        "auto" when the log does not say).
    """

    name: str
    root: Path
    config: TrainConfig
    fits_source: str

    @property
    def is_floor(self) -> bool:
        return self.config.method == "rgb"

    @property
    def holdout(self) -> int:
        return self.config.holdout

    @property
    def holdout_by(self) -> str:
        return self.config.holdout_by


def run_fits_source(run_dir: Path) -> str:
    """The fits source a run's train.log names ("fits: <source>; frames cache: ..."), else "auto"."""
    return RunFiles(run_dir).fits_source()


def read_run(run_dir: Path) -> RunInfo:
    run = RunDir(run_dir)
    return RunInfo(run.root.name, run.root, run.load_config(), run_fits_source(run.root))


def finished_runs(project) -> list[RunInfo]:
    """Every run of the project with an ``avatar.pt``, oldest avatar first."""
    return [read_run(d) for d in finished_run_dirs(project)]


def select_runs(project, names: tuple[str, ...] | list[str] = ()) -> list[RunInfo]:
    """The named runs (in the order given), or every finished run; one-line errors otherwise."""
    root = Path(project.runs_dir)
    if not names:
        runs = finished_runs(project)
        if not runs:
            raise ProjectError(f"no finished training run in {root}; run 'morf train {project.root} --holdout 8' first")
        return runs
    out = []
    for name in dict.fromkeys(names):
        d = run_path(project, name)
        if not d.is_dir():
            known = ", ".join(r.name for r in finished_runs(project)) or "none"
            raise ProjectError(f"no run named {name!r} in {root} (finished runs: {known})")
        if not RunFiles(d).is_done:
            raise ProjectError(f"run {name!r} has not finished (no {AVATAR_FILE}); resume it with 'morf train'")
        out.append(read_run(d))
    return out


def find_floor(project, holdout: int, fits_source: str | None = None, holdout_by: str = "frame") -> RunInfo | None:
    """The newest finished RGB floor run with this hold-out setting (and these fits, when given), if any."""
    floors = [r for r in finished_runs(project) if r.is_floor and r.holdout == holdout and r.holdout_by == holdout_by
              and (fits_source is None or r.fits_source == fits_source)]
    return floors[-1] if floors else None


def free_for_floor(run_dir: Path) -> bool:
    """Whether ``run_dir`` is free for a floor: absent, empty of a config, or an RGB floor's."""
    run = RunDir(run_dir)
    if not run.config_path.is_file():
        return not run.avatar_path.is_file()
    try:
        return run.load_config().method == "rgb"
    except MorfError:
        return False


def floor_run_name(project, holdout: int, fits_source: str, holdout_by: str = "frame") -> str:
    """The name ``morf eval`` gives a floor it builds: ``rgb-holdout<K>``, with the fits source
    appended when that name holds a floor built on other fits, and the hold-out rule when it
    holds one of the other rule."""
    name = f"rgb-holdout{holdout}"
    d = Path(project.runs_dir) / name
    if RunFiles(d).is_done and run_fits_source(d) != fits_source:
        name += f"-{fits_source}"
    d = Path(project.runs_dir) / name
    if RunFiles(d).is_done and read_run(d).holdout_by != holdout_by:
        name += f"-{holdout_by}s"
    return name
