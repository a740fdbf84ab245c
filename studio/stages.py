"""Which pipeline stages the studio can drive, found lazily in the library.

The fitting, training and export stages live in ``morf.fitting``, ``morf.train`` and
``morf.export``. They are imported only when the studio starts, and a stage whose module or
function is missing is listed as unavailable with the reason (the UI shows it, greyed out).

A library stage is a function ``f(project, config, control)`` (any of those parameter names may be
positional or keyword). Its config, when it has one, is the module's config dataclass: the named
preset the UI chose (``options["preset"]``, through the module's ``preset(name)``), or the
dataclass's defaults, with the UI's other overrides applied with ``dataclasses.replace``.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import time
from dataclasses import dataclass
from typing import Callable

from morf.capture.project import CaptureProject
from morf.errors import InputError
from morf.pipeline.control import Progress, StageControl
from studio.worker import StageFn


@dataclass(frozen=True)
class StageSpec:
    """Where to look for one stage in the library."""

    name: str  # the key the UI uses ("fit")
    label: str  # button text ("Fit body")
    modules: tuple[str, ...]  # where to look, in order ("morf.fitting", "morf.fitting.project_fit")
    functions: tuple[str, ...]  # candidate function names, first found wins
    configs: tuple[str, ...]  # candidate config dataclass names (looked up in the same modules)
    presets: tuple[str, ...] = ()  # candidate preset tables name -> config (looked up in the same modules)


LIBRARY_STAGES = (
    StageSpec("fit", "Fit body", ("morf.fitting", "morf.fitting.project_fit", "morf.fitting.config"),
              ("fit_project",), ("FitConfig",), ("PRESETS",)),
    StageSpec("train", "Train avatar", ("morf.train", "morf.train.project_run", "morf.train.config"),
              ("train_project",), ("TrainConfig",), ("PRESETS",)),
    StageSpec("export", "Export", ("morf.export.project_export",),
              ("export_project",), ("ProjectExportConfig",)),
)


def stage_config(config_cls: type, presets: dict | None, options: dict):
    """The config a stage runs with: ``options["preset"]`` (or the defaults) + the other options."""
    options = dict(options)
    name = options.pop("preset", None)
    if name is not None:
        if not presets or name not in presets:
            raise InputError(f"unknown preset {name!r}; choose one of {', '.join(presets or ()) or '(none)'}")
        base = presets[name]
    else:
        base = config_cls()
    config = dataclasses.replace(base, **options)
    validate = getattr(config, "validate", None)
    if callable(validate):
        validate()
    return config


def _adapt(fn: Callable, config_cls: type | None, presets: dict | None = None) -> StageFn:
    params = inspect.signature(fn).parameters

    def run(project: CaptureProject, control: StageControl, options: dict):
        config = stage_config(config_cls, presets, options) if config_cls is not None else None
        kwargs = {}
        for name in params:
            if name in ("project", "capture"):
                kwargs[name] = project
            elif name in ("config", "cfg") and config is not None:
                kwargs[name] = config
            elif name == "control":
                kwargs[name] = control
        return fn(**kwargs)

    run.presets = tuple(presets or ())  # names the UI offers
    return run


def find_library_stages() -> tuple[dict[str, StageFn], dict[str, str]]:
    """(available name -> stage function, unavailable name -> reason in words)."""
    found: dict[str, StageFn] = {}
    missing: dict[str, str] = {}
    for spec in LIBRARY_STAGES:
        modules, errors = [], []
        for name in spec.modules:
            try:
                modules.append(importlib.import_module(name))
            except ImportError as e:
                errors.append(str(e))
        fn = next((getattr(m, n) for m in modules for n in spec.functions if callable(getattr(m, n, None))), None)
        if fn is None:
            why = f"no {' / '.join(spec.functions)} in {spec.modules[0]}"
            missing[spec.name] = why + (f" ({errors[0]})" if errors and not modules else "")
            continue
        config_cls = next((getattr(m, n) for m in modules for n in spec.configs
                           if dataclasses.is_dataclass(getattr(m, n, None))), None)
        presets = next((getattr(m, n) for m in modules for n in spec.presets
                        if isinstance(getattr(m, n, None), dict)), None)
        found[spec.name] = _adapt(fn, config_cls, presets)
    return found, missing


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
