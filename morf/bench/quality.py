"""``morf bench quality --out DIR [--preset tiny|cpu|gpu] [--seeds N]``: avatar quality on frames
no run trained on, every learned method against the no-learning RGB floor.

On a synthetic capture (made in ``DIR/capture`` and fitted, see :mod:`morf.bench.quality_capture`;
``--project`` names an existing one) every learned method of ``--methods`` (default morf and
stylepeople; anr on request) is trained ``--seeds`` times with seeds 0..N-1 on the fitted bodies
(``--fits fits``; ``ground-truth`` trains on the capture's true poses) with every ``--holdout``-th
usable frame kept out, and the RGB floor (method rgb, deterministic) is built once with the same
frames (:mod:`morf.bench.quality_runs`). Then :func:`morf.evaluate.project_eval.evaluate_project`
scores every run on two blocks: the synthetic hold-out sequence (``novel-poses``: poses the
capture never showed) and the held-out capture frames (``holdout-k<K>``, in their fitted poses;
none with ``--holdout 0``). Per block and method: means, per-seed values and spread of the
metrics (:mod:`morf.bench.quality_scores`) and the targets (:mod:`morf.bench.quality_checks`).

Writes into DIR: ``quality.json``, ``quality.md`` (:mod:`morf.bench.quality_report`), and what
``morf eval`` writes: ``eval.json`` (every run's scores), ``sheet-<block>.png`` (real | each
method's seed-0 run | floor) and ``yt-<block>.png`` (y-t slices). ``quality.json``:
``{"preset", "project", "fits", "holdout", "seeds", "methods", "blocks": {key: {"title", "frames",
"sheet", "slices", "methods": {method: {"mean", "seeds", "spread", "diverged"}}, "checks"}},
"runs": [...], "training_checks", "targets_missed", "targets_not_measured", "machine", ...}``.
LPIPS (:mod:`morf.avatar.lpips`) is scored when ``--lpips PATH`` (or ``$MORF_LPIPS_WEIGHTS``) names
the ``lpips`` package's ``weights/v0.1/vgg.pth`` and ``--vgg`` (or ``$MORF_VGG16_WEIGHTS``) the
VGG-16 weights, which the trainings then use for their perceptual loss too; null otherwise.
"""

from __future__ import annotations

import os
from pathlib import Path

METHODS = ("morf", "stylepeople", "anr")  # the learned methods
DEFAULT_METHODS = "morf,stylepeople,rgb"


def parse_methods(text: str) -> list[str]:
    """The learned methods named in ``text`` (the floor, always run, may be named too)."""
    from morf.bench.quality_runs import FLOOR
    from morf.errors import InputError

    names = list(dict.fromkeys(m.strip() for m in text.split(",") if m.strip()))
    bad = [m for m in names if m not in METHODS and m != FLOOR]
    if bad:
        raise InputError(f"unknown method(s) {', '.join(bad)}; choose from {', '.join(METHODS + (FLOOR,))}")
    return [m for m in names if m != FLOOR]


def _check_counts(seeds: int, holdout: int, steps: int | None) -> None:
    """Refuse counts that make no benchmark, before anything is made or loaded."""
    from morf.errors import InputError

    if seeds < 1:
        raise InputError(f"--seeds must be at least 1, got {seeds}")
    if holdout < 0 or holdout == 1:
        raise InputError(f"--holdout must be 0 (none) or at least 2 (every K-th frame), got {holdout}")
    if steps is not None and steps < 1:
        raise InputError(f"--steps must be at least 1, got {steps}")


def run_quality(out: Path, preset: str, methods: list[str], *, seeds: int = 1, holdout: int = 5,
                steps: int | None = None, fits: str = "fits", vgg: str | None = None,
                lpips: str | None = None, project_path: str | None = None, model=None,
                refine_poses: bool = False) -> dict:
    """Train, evaluate and write everything into ``out``; returns the quality.json content."""
    from morf.avatar.lpips import find_lpips
    from morf.bench.common import machine_info, write_results
    from morf.bench.quality_capture import bench_capture
    from morf.bench.quality_checks import block_checks, training_checks
    from morf.bench.quality_report import quality_markdown
    from morf.bench.quality_runs import FLOOR, TrainPlan, train_runs
    from morf.bench.quality_scores import block_scores
    from morf.evaluate.project_eval import EvalConfig, evaluate_project, format_table
    from morf.train.data import load_body_fits

    _check_counts(seeds, holdout, steps)
    find_lpips(lpips, vgg)  # bad LPIPS or VGG-16 files fail now, not after the trainings
    if model is None:
        from morf.body import load_body_model

        model = load_body_model("anny")
    out = Path(out)
    project = bench_capture(out, preset, project_path, fits, model)
    source = load_body_fits(project, fits).source
    runs = train_runs(project, TrainPlan(preset, holdout, steps, source, vgg), methods, seeds, model)
    scored = [r for r in runs if not r.diverged]
    first = {}
    for r in scored:
        first.setdefault(r.method, r.name)  # each method's column on the sheets: its first scored seed
    ev = evaluate_project(project, EvalConfig(runs=tuple(r.name for r in scored), out=str(out), floor=False,
                                              sheet_runs=tuple(first.values()), lpips=lpips, vgg=vgg,
                                              refine_poses=refine_poses, force=True),  # DIR is the bench's own
                          model, say=print)
    print(format_table(ev))
    keys = sorted(ev.targets, key=lambda k: k != "novel-poses")  # novel poses first, as before
    blocks = [block_scores(ev, k, runs) for k in keys]
    blocks = [(b, block_checks(b, FLOOR)) for b in blocks]
    plateaus = [r.plateau_minutes for r in runs if r.method == "morf" and r.plateau_minutes is not None]
    training = training_checks(sum(plateaus) / len(plateaus) if plateaus else None)
    head = {"benchmark": "quality", "preset": preset, "project": str(project.root), "fits": source,
            "holdout": holdout, "seeds": seeds, "steps": steps, "methods": methods + [FLOOR], "poses": ev.poses}
    every = [(b.key, c) for b, c in blocks] + [("training", training)]
    result = {**head, "blocks": {b.key: {**b.to_dict(), "checks": c.to_dict()} for b, c in blocks},
              "runs": [r.to_dict() for r in runs], "training_checks": training.to_dict(),
              "targets_missed": [f"{k}: {n}" for k, c in every for n, met in c.met.items() if met is False],
              "targets_not_measured": [f"{k}: {n}" for k, c in every for n, met in c.met.items() if met is None],
              "eval": "eval.json", "lpips": ev.lpips, "machine": machine_info(),
              # the load average says how much of the shared CPU the run actually had
              "load_average": list(os.getloadavg())}
    path = write_results(out, "quality", result, quality_markdown(head, blocks, runs, training))
    print("targets missed: " + (", ".join(result["targets_missed"]) or "none")
          + f"; not measured: {len(result['targets_not_measured'])}")
    print(f"wrote {path}")
    return result
