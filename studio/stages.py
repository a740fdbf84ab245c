"""The pipeline stages the studio runs: a plain table of the library's stage functions.

Each row of :data:`LIBRARY_STAGES` names a stage, its button and a function that imports the
library's stage (``morf.fitting``, ``morf.train``, ``morf.export``) and returns it ready for the
worker. The studio loads the table when it starts; a stage whose import fails for any reason
cannot run, and the Training panel shows the error (the exception itself, in red).

A stage as the worker runs it is ``(project, control, options) -> result`` (:data:`StageFn`).
``options["preset"]`` names one of the stage's presets in :mod:`morf.presets` (without it the
stage's default preset, the one the CLI picks); the other options replace config fields.
"""

from __future__ import annotations

import dataclasses
import sys
import time
import traceback
from dataclasses import dataclass
from typing import Callable

from morf.capture.project import CaptureProject
from morf.errors import InputError
from morf.pipeline.control import Progress, StageControl
from studio.worker import StageFn


def stage_config(stage: str, options: dict, plain: type | None = None):
    """The config a stage runs with: ``options["preset"]`` (default: the stage's default preset in
    :mod:`morf.presets`) with the other options replacing fields, validated.

    ``plain``: the config dataclass of a stage without presets; its defaults are the base then.
    Unknown fields and a preset for a stage without presets are an :class:`InputError`.
    """
    options = dict(options)
    name = options.pop("preset", None)
    if plain is None:
        from morf.presets import default_preset, preset

        base = preset(stage, name or default_preset(stage))
    elif name is not None:
        raise InputError(f"the {stage} stage has no presets (asked for {name!r})")
    else:
        base = plain()
    unknown = set(options) - {f.name for f in dataclasses.fields(base)}
    if unknown:
        raise InputError(f"unknown {stage} config fields: {', '.join(sorted(unknown))}")
    config = dataclasses.replace(base, **options)
    config.validate()
    return config


def _fit_stage() -> StageFn:
    from morf.fitting.project_fit import fit_project

    def fit(project: CaptureProject, control: StageControl, options: dict):
        return fit_project(project, stage_config("fit", options), control=control)

    return fit


def _train_stage() -> StageFn:
    from morf.train.project_run import train_project

    def train(project: CaptureProject, control: StageControl, options: dict):
        return train_project(project, stage_config("train", options), control=control)

    return train


def _export_stage() -> StageFn:
    from morf.export.project_export import ProjectExportConfig, export_project

    def export(project: CaptureProject, control: StageControl, options: dict):
        return export_project(project, stage_config("export", options, ProjectExportConfig), control=control)

    return export


@dataclass(frozen=True)
class LibraryStage:
    """One stage the studio offers: its button and how to load it."""

    name: str  # the key the UI and the worker use ("fit")
    label: str  # button text ("Fit body")
    load: Callable[[], StageFn]  # imports the library and returns the stage; raises when it cannot
    presets: bool = False  # the stage has named presets in morf.presets, under ``name``


LIBRARY_STAGES: tuple[LibraryStage, ...] = (
    LibraryStage("fit", "Fit body", _fit_stage, presets=True),
    LibraryStage("train", "Train avatar", _train_stage, presets=True),
    LibraryStage("export", "Export", _export_stage),
)


@dataclass(frozen=True)
class LoadedStages:
    """What :func:`load_library_stages` found."""

    functions: dict[str, StageFn]  # stage name -> the function the worker runs
    errors: dict[str, str]  # stage name -> why it could not be loaded ("ModuleNotFoundError: ...")
    presets: dict[str, tuple[str, ...]]  # stage name -> its preset names, as the UI offers them
    default_presets: dict[str, str]  # stage name -> the preset it runs with when none is chosen


def load_library_stages(table: tuple[LibraryStage, ...] = LIBRARY_STAGES) -> LoadedStages:
    """Load every stage of ``table``; one that fails is reported in ``errors``, the others still load."""
    functions, errors, presets, defaults = {}, {}, {}, {}
    for stage in table:
        try:
            fn = stage.load()
            if stage.presets:
                from morf.presets import default_preset, presets_of

                presets[stage.name] = tuple(presets_of(stage.name))
                defaults[stage.name] = default_preset(stage.name)
        except Exception as e:  # whatever breaks an import (a missing package, a bad install) is shown, not raised
            traceback.print_exc(file=sys.stderr)
            errors[stage.name] = f"{type(e).__name__}: {e}"
            continue
        functions[stage.name] = fn
    return LoadedStages(functions, errors, presets, defaults)


def cpu_load_stage(project: CaptureProject, control: StageControl, options: dict) -> None:
    """A benchmark-only stage: matrix products that keep the worker's cores busy for a while.

    Used by ``morf-studio --stage cpu-load --frame-times`` to measure UI frame times under load
    when no real stage is wanted. options: ``seconds`` (default 30), ``size`` (default 512).
    """
    import torch

    seconds, size = float(options.get("seconds", 30.0)), int(options.get("size", 512))
    a = torch.randn(size, size)
    start, step = time.monotonic(), 0
    while time.monotonic() - start < seconds:
        control.check()
        b = a @ a
        a = b / b.norm()
        step += 1
        if step % 10 == 0:
            control.report(Progress("cpu-load", step=step, message="keeping the CPU busy",
                                    losses={"norm": float(b.norm())}))
