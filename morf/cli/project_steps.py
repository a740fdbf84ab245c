"""The stages of a capture project as ``morf`` sub-commands, each planned from what the project
already holds: ingest, fit, train, export. Shared by ``morf run`` and ``morf demo`` (the chaining
itself is :mod:`morf.pipeline.chain`).

What counts as done, and who says so:
    ingest  the project's manifest exists (ingest swaps a finished project in whole).
    fit     fits/done.json names the fit and every output it lists exists: fits.npz, filter.json,
            an overlay per frame (:func:`morf.fitting.project_fit.fit_progress`); anything less
            is a fit to resume, with the options that started it.
    train   runs/<name>/avatar.pt exists (``RunDir.is_done``); a run folder with its config
            is resumed from its checkpoint with that very config.
    export  PROJECT/avatar was exported from that run after it finished
            (:func:`morf.export.project_export.exported_run`).
"""

from __future__ import annotations

from pathlib import Path

from morf.errors import InputError
from morf.pipeline.chain import Plan

# ``morf fit`` switches (all "--no-NAME") and the FitConfig fields they turn off
FIT_SWITCHES = {"shared_shape": "--no-shared-shape", "silhouette": "--no-silhouette", "temporal": "--no-temporal",
                "frame_filter": "--no-frame-filter", "overlays": "--no-overlays"}


def fit_plan(root: Path, preset: str) -> Plan:
    """Skip complete fits; resume a stopped fit with the options it was started with (when
    ``morf fit`` options can say them); else fit with ``preset``."""
    from morf.capture.project import CaptureProject
    from morf.fitting.project_fit import fit_progress

    progress = fit_progress(CaptureProject.open(root))
    if progress.complete:
        return Plan("skip", note="fits in fits/")
    fresh = ("fit", str(root), "--preset", preset)
    if progress.started and progress.config is not None:
        options = fit_options(progress.config)
        if options is not None:
            return Plan("resume", ("fit", str(root), *options),
                        f"after stage {progress.stages_done} of {progress.stages_total}")
        return Plan("run", fresh, "the stopped fit's settings are no preset; starting over")
    return Plan("run", fresh)


def fit_options(config) -> tuple[str, ...] | None:
    """``morf fit`` options that give exactly ``config`` (a FitConfig), or None when none do."""
    from morf.presets import PRESETS

    for name, base in PRESETS["fit"].items():
        switches = [flag for field, flag in FIT_SWITCHES.items() if getattr(base, field) and not getattr(config, field)]
        if any(getattr(config, field) and not getattr(base, field) for field in FIT_SWITCHES):
            continue  # the switches only turn things off
        try:
            same = base.replace(**{field: getattr(config, field) for field in FIT_SWITCHES}) == config
        except InputError:
            continue
        if same:
            return ("--preset", name, *switches)
    return None


def train_plan(root: Path, name: str, fresh: tuple[str, ...], holdout: int | None = None) -> Plan:
    """Skip a finished run ``name``; resume a started one with its own saved config; else run
    ``fresh`` (a ``morf train`` command line). ``holdout``: the hold-out the user asked for (a
    finished or started run with another one is an error rather than a silent mismatch)."""
    from morf.capture.project import CaptureProject
    from morf.train.run_dir import RunDir
    from morf.train.run_files import run_path

    run = RunDir(run_path(CaptureProject.open(root), name))
    if run.config_path.is_file():
        cfg = run.load_config()
        if holdout is not None and cfg.holdout != holdout:
            raise InputError(f"run {name!r} in {root} holds out every {cfg.holdout}th frame (--holdout {cfg.holdout}), "
                             f"not every {holdout}th; give --holdout {cfg.holdout} or another --preset")
        from morf.train.view_colours import view_colours_missing

        if run.is_done and not view_colours_missing(run):
            return Plan("skip", note=f"run runs/{name}")
        step = ("to add its view colours" if run.is_done else
                "from its checkpoint" if run.has_checkpoint else "from its start")
        argv = ("train", str(root), "--config", str(run.config_path), "--name", name, "--device", cfg.device)
        return Plan("resume", argv, step)
    if run.is_done:
        return Plan("skip", note=f"run runs/{name}")
    return Plan("run", fresh)


def export_plan(root: Path, run: str) -> Plan:
    """Skip when PROJECT/avatar is the current export of ``run``; else export it."""
    from morf.capture.project import CaptureProject
    from morf.export.project_export import exported_run

    if exported_run(CaptureProject.open(root)) == run:
        return Plan("skip", note=f"{Path(root) / 'avatar'} from run {run}")
    return Plan("run", ("export", str(root), "--run", run))
