"""``morf bench pareto --out DIR [--preset tiny|quick|default]``: speed against accuracy.

On one synthetic capture (made in ``DIR/capture-<scene>`` unless ``--project`` names one), each
point of the sweep (:mod:`morf.sizing.sweep`: renderer architecture, neural texture resolution
and channels, training resolution, steps and learning-rate schedule, warp on/off, int8 vs fp32)
is trained and measured:

* hold-out quality: PSNR / SSIM over the image and over the person, temporal flicker (the
  evaluation of ``morf bench quality``); the fronts use ``psnr_person``;
* live playback fps at ``fps_size``^2 (640 except in the tiny preset), end to end, int8 unless
  the point is fp32, measured in a torch-free child process (``morf.bench.render``);
* training minutes (wall time of the training loop, all sessions).

Writes ``DIR/pareto.json`` ``{"points": [...], "front_fps": [...], "front_train": [...], ...}``,
``DIR/pareto.md`` and charts ``DIR/pareto_fps.png``, ``DIR/pareto_train.png``. Resumable: each
point's result is saved in ``DIR/points/<name>.json`` as it finishes and reused on a re-run (its
training run also resumes); ``--points`` names what to measure, and points measured earlier in
``DIR`` on the same capture stay in the results. ``--auto-check`` runs the automatic size choice on three scenes
instead (see :mod:`morf.bench.auto_check`, which runs this sweep per scene).

The trainings run as Ray tasks (:mod:`morf.scale`), each distinct training once (int8 and fp32 of
one model share it): on a local Ray by default, on a cluster with ``--address``. Each holds
``--cpus-per-task`` cores, by default all of this machine's, so on one machine the points train one
after another on every core as the training-minutes axis has always meant; fewer cores per task
train several at once. Playback speed is then measured here, one point after another, with no
training running beside it, once per run and machine: a point whose training another point or
scene already timed reads that run's stored speed (:mod:`morf.bench.run_speed`).
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.bench.pareto_results import PAPER_NOTE, QUALITY, FloorPoint, PointRow, SweepResult
from morf.bench.train_eval import TrainEvaluation


def make_capture(out: Path, sweep, scene: str, model, project_path: str | None = None):
    """The sweep's capture: ``project_path`` when given (must be synthetic), else ``OUT/capture-<scene>``."""
    from morf.capture.project import CaptureProject
    from morf.errors import InputError
    from morf.sizing.sweep import SCENES
    from morf.synth.ground_truth import has_holdout

    if project_path:
        project = CaptureProject.open(project_path)
        if not has_holdout(project):
            raise InputError(f"{project.root} has no hold-out sequence (a synthetic capture is needed)")
        return project
    root = out / f"capture-{scene}"
    if CaptureProject.is_project(root) and has_holdout(root):
        return CaptureProject.open(root)
    from morf.synth import make_synthetic_capture, synth_config

    name, overrides = sweep.synth
    cfg = synth_config(name, **{**overrides, **SCENES[scene]})
    print(f"making a synthetic capture ({scene}: {cfg.frames} frames, {cfg.size}x{cfg.size}) in {root}")
    return make_synthetic_capture(root, cfg, model=model, overwrite=True)


def _summary(cfg) -> dict:
    return {"renderer": dataclasses.asdict(cfg.renderer), "texture_size": cfg.texture_size,
            "texture_channels": cfg.texture_channels, "resolution": cfg.resolution, "steps": cfg.steps,
            "method": cfg.method}


@dataclass(frozen=True)
class Training:
    """One training a benchmark needs, as a Ray task gets it (paths and a config, nothing loaded).

    Fields:
        root: the capture project's folder; cfg: the TrainConfig; run: run name (``ROOT/runs/<run>``);
        fits_source: ground-truth | fits; eval_resolution: hold-out scoring size in px (None: the
            training resolution).
    """

    root: str
    cfg: object
    run: str
    fits_source: str = "ground-truth"
    eval_resolution: int | None = None


def train_point_task(root: str, cfg, run: str, fits_source: str, eval_resolution: int | None) -> TrainEvaluation:
    """On a Ray worker: train (or resume, or reuse) ``ROOT/runs/<run>`` and score it on the hold-out
    (:func:`morf.bench.train_eval.train_and_evaluate`); the body model is loaded once per worker."""
    from morf.bench.train_eval import train_and_evaluate
    from morf.body import load_body_model
    from morf.capture.project import CaptureProject
    from morf.scale.tasks import worker_cached

    model = worker_cached("body-model:anny", lambda: load_body_model("anny"))
    return train_and_evaluate(CaptureProject.open(root), cfg, run, model, fits_source, eval_resolution)


def train_all(trainings, ray=None, workers: int | None = None, cpus_per_task: int | None = None) -> dict:
    """Every distinct training of ``trainings`` (one per project and run name) as a Ray task
    (:func:`train_point_task`; in this process with ``RayOptions(in_process=True)``),
    ``cpus_per_task`` cores each (None: all of this machine's);
    {(root, run): Outcome}. A training that raised is an outcome with an error; the others go on."""
    from morf.scale.ray_runtime import resources_for
    from morf.scale.tasks import Task, run_tasks, threads_here

    unique: dict[tuple[str, str], Training] = {}
    for t in trainings:
        unique.setdefault((t.root, t.run), t)
    cpus = cpus_per_task or os.cpu_count() or 1
    short = [f"{Path(root).name}/{run}" for root, run in unique]  # a task's name: capture folder / run
    names = [n if short.count(n) == 1 else f"{root}/{run}" for n, (root, run) in zip(short, unique)]
    tasks = [Task(name, train_point_task, (t.root, t.cfg, t.run, t.fits_source, t.eval_resolution),
                  resources_for(t.cfg.preset, cpus)) for name, t in zip(names, unique.values())]
    done = []

    def report(o):
        done.append(o)
        state = f"in {o.seconds:.0f} s" if o.ok else f"failed: {o.error}"
        print(f"  trained {len(done)}/{len(tasks)}: {o.name} {state}")

    if tasks:
        plural = lambda n, word: f"{n} {word}{'s' if n > 1 else ''}"  # noqa: E731
        if ray is not None and ray.in_process:
            threads = threads_here(tasks[0].resources)
            print(f"training {plural(len(tasks), 'run')} in this process, one after another, "
                  f"{plural(threads, 'thread')} each")
        else:
            print(f"training {plural(len(tasks), 'run')} on Ray, {plural(cpus, 'core')} each")
    return dict(zip(unique, run_tasks(tasks, ray, workers, report)))


def seed_repeats(pairs, seeds: int) -> dict[str, list]:
    """{name: [(SweepPoint, TrainConfig), ...]}: each point trained again with ``seeds - 1``
    further seeds (base seed + 1, ...), named ``<name>-seed<seed>`` (saved as
    ``OUT/points/<name>-seed<seed>.json``); the seed axis's points are not repeated."""
    from morf.sizing.sweep import NOISE_AXES, SweepPoint

    out = {}
    for point, cfg in pairs:
        if point.axis in NOISE_AXES:
            continue
        out[point.name] = [(SweepPoint(f"{point.name}-seed{cfg.seed + k}", point.axis,
                                       {**point.change, "seed": cfg.seed + k}, point.method, point.precision),
                            cfg.replace(seed=cfg.seed + k)) for k in range(1, seeds)]
    return out


def measure_points(project, sweep, pairs, model, out: Path, ray=None, workers: int | None = None,
                   cpus_per_task: int | None = None) -> dict[str, tuple[PointRow, bool]]:
    """Train, evaluate and time the (SweepPoint, TrainConfig) ``pairs``; {name: (result, reused)}
    where reused means loaded from ``OUT/points/<name>.json`` (same config, same fps size) without
    any work. The trainings run on Ray (:func:`train_all`); then each point's playback speed is
    measured here and its result saved as it is complete."""
    from morf.bench.run_speed import speed_of_run_once
    from morf.io import atomic_write_json
    from morf.scale.tasks import Outcome, TasksFailed
    from morf.sizing.sweep import train_key

    results: dict[str, tuple[PointRow, bool]] = {}
    need = []
    for point, cfg in pairs:
        old = saved_point(out, sweep, point, project, cfg)
        if old is not None:
            results[point.name] = (old, True)
        else:
            root = str(Path(project.root).resolve())
            key, eval_res = _identity(sweep, point, cfg)
            need.append((point, cfg, key, Training(root, cfg, f"pareto-{train_key(cfg)}", eval_resolution=eval_res)))
    trained = train_all([t for _, _, _, t in need], ray, workers, cpus_per_task)
    failed = []
    for point, cfg, key, t in need:
        o = trained[(t.root, t.run)]
        if not o.ok:
            failed.append(Outcome(point.name, error=o.error))
            continue
        t0 = time.time()
        ev: TrainEvaluation = o.value
        speed = None if ev.diverged else speed_of_run_once(ev.run, out / "work", sweep.fps_size, sweep.fps_frames,
                                                           point.precision, model)[0]
        row = PointRow(point.name, point.axis, cfg.method, point.precision, key, _summary(cfg), ev, speed,
                       o.seconds + time.time() - t0)
        atomic_write_json(out / "points" / f"{point.name}.json", row.to_dict())
        results[point.name] = (row, False)
    if failed:
        raise TasksFailed("sweep points", failed)
    return results


def mean_of_runs(runs: list[PointRow], key: str) -> float | None:
    """Mean of :meth:`PointRow.metric` ``key`` over the runs that have it (None when none has)."""
    vals = [v for v in (r.metric(key) for r in runs) if v is not None]
    return sum(vals) / len(vals) if vals else None


SEED_KEYS = (QUALITY, "ssim_person", "psnr", "temporal", "fps", "train_minutes")  # averaged over seeds


def with_seeds(row: PointRow, again: list[PointRow]) -> PointRow:
    """``row`` with the values of :data:`SEED_KEYS` over its trainings (``row`` and ``again``) and their means."""
    runs = [row] + again
    return dataclasses.replace(row, seed_runs={k: [r.metric(k) for r in runs] for k in SEED_KEYS},
                               seed_means={k: mean_of_runs(runs, k) for k in SEED_KEYS})


def fronts(rows: list[PointRow]) -> dict[str, np.ndarray]:
    """Pareto fronts of quality against fps (both up) and against training minutes (down), on the
    means over the seeds where a point has several."""
    from morf.bench.front import pareto_front

    q = [r.mean(QUALITY) for r in rows]
    fps = [[a, r.mean("fps")] for a, r in zip(q, rows)]
    train = [[a, r.mean("train_minutes")] for a, r in zip(q, rows)]
    none = lambda v: [[np.nan if x is None else x for x in p] for p in v]  # noqa: E731
    return {"fps": pareto_front(none(fps), (True, True)), "train": pareto_front(none(train), (True, False))}


def seed_spread(rows: list[PointRow]) -> dict | None:
    """The base point's quality over the seeds the sweep trained it with (the base and the seed
    axis's points that did not diverge): {"points", QUALITY, "range_db", "std_db"}; None without
    seed points."""
    from morf.sizing.sweep import NOISE_AXES

    runs = [r for r in rows if (r.axis == "base" or r.axis in NOISE_AXES) and r.metric(QUALITY) is not None]
    if not any(r.axis in NOISE_AXES for r in runs) or len(runs) < 2:
        return None
    q = np.array([r.metric(QUALITY) for r in runs], float)
    return {"points": [r.name for r in runs], QUALITY: q.tolist(), "range_db": float(np.ptp(q)),
            "std_db": float(q.std(ddof=1))}


def floor_point(project, sweep, model) -> FloorPoint:
    """The RGB floor (no learning, :mod:`morf.train.floor`) on the base point's frames, scored as
    the points are; its playback speed is not measured (it cannot be exported)."""
    from morf.bench.train_eval import holdout_quality
    from morf.sizing.sweep import SweepPoint, resolve
    from morf.train.floor import floor_request, train_floor

    base = resolve(sweep, SweepPoint("base", "base"))
    res = train_floor(project, floor_request(base.resolution, base.holdout), f"pareto-rgb-{base.resolution}",
                      "ground-truth", model)
    m = holdout_quality(project, res.run_dir, model, base.resolution)
    return FloorPoint(str(res.run_dir), m.psnr_person, m.ssim_person, m.psnr, m.temporal)


def charts(rows: list[dict], front: dict, out: Path, fps_size: int, title: str,
           noise: dict | None = None, floor: FloorPoint | None = None) -> list[str]:
    from morf.bench.charts import front_chart

    paper = fps_size == 640
    base = next((r for r in rows if r["axis"] == "base"), None)
    spread = lambda x: (base[x], min(noise[QUALITY]), max(noise[QUALITY])) if noise and base else None  # noqa: E731
    ref = {"reference_y": floor.metric(QUALITY), "reference_label": floor.name} if floor is not None else {}
    a = front_chart(rows, "fps", QUALITY, front["fps"], out / "pareto_fps.png", spread=spread("fps"), **ref,
                    title=f"{title}: quality vs live fps", xlabel=f"fps at {fps_size}x{fps_size}, end to end, this CPU",
                    ylabel="hold-out PSNR on the person (dB)", target_x=30.0 if paper else None,
                    target_label="paper: 30 fps @640, Snapdragon 888", note=PAPER_NOTE if paper else
                    f"Measured at {fps_size}x{fps_size} (not the paper's 640x640): no paper reference applies.")
    b = front_chart(rows, "train_minutes", QUALITY, front["train"], out / "pareto_train.png",
                    spread=spread("train_minutes"), **ref,
                    title=f"{title}: quality vs training time", xlabel="training minutes (this CPU)",
                    ylabel="hold-out PSNR on the person (dB)", log_x=True,
                    note="The paper gives no comparable training time.")
    return [str(a), str(b)]


def _identity(sweep, point, cfg) -> tuple[str, int]:
    """(key, scoring resolution) a saved point must match: its training config, precision and fps
    size; quality is scored at the base point's training resolution, so the resolution axis compares
    like with like."""
    from morf.sizing.sweep import SweepPoint, resolve, train_key

    return (f"{train_key(cfg)}-{point.precision}-{sweep.fps_size}",
            resolve(sweep, SweepPoint("base", "base")).resolution)


def saved_point(out: Path, sweep, point, project, cfg=None) -> PointRow | None:
    """``OUT/points/<name>.json`` when it holds this point's config (same training, fps size and
    scoring resolution) trained on ``project``; else None."""
    from morf.sizing.sweep import resolve

    key, eval_res = _identity(sweep, point, cfg or resolve(sweep, point))
    path = out / "points" / f"{point.name}.json"
    if not path.is_file():
        return None
    old = json.loads(path.read_text())
    same_capture = Path(old.get("run", "")).resolve().is_relative_to(Path(project.root).resolve())
    # results saved before eval_resolution was kept were scored at their own resolution
    scored_at = old.get("eval_resolution", old["config"]["resolution"])
    return PointRow.from_dict(old) if old.get("key") == key and scored_at == eval_res and same_capture else None


def _mark_fronts(rows: list[PointRow]) -> tuple[list[PointRow], dict[str, np.ndarray], list[int]]:
    """The rows with ``on_front_fps`` / ``on_front_train`` set, the fronts (:func:`fronts`, over
    the sized points), and the indices of those sized points (the seed axis's stay off the fronts)."""
    from morf.sizing.sweep import NOISE_AXES

    sized = [i for i, r in enumerate(rows) if r.axis not in NOISE_AXES]
    front = fronts([rows[i] for i in sized])
    on = dict(zip(sized, zip(front["fps"], front["train"])))
    marked = []
    for i, r in enumerate(rows):
        f1, f2 = on.get(i, (False, False))
        marked.append(dataclasses.replace(r, on_front_fps=bool(f1), on_front_train=bool(f2)))
    return marked, front, sized


def _markdown(result: SweepResult, shown: list[dict], fps_size: int) -> str:
    """pareto.md: the table of ``shown`` (the sized points with their seed means, then the seed
    axis's points), what the numbers mean, the seed noise and the RGB floor."""
    from morf.bench.common import markdown_table

    seeds, noise, floor = result.seeds, result.seed_spread, result.floor
    table = [{**r, "params_M": r["params"] / 1e6, "front": ("fps " if r["on_front_fps"] else "")
              + ("train" if r["on_front_train"] else "")} for r in shown]
    cols = ["name", "params_M", "psnr_person", "ssim_person", "psnr", "temporal", "fps", "renderer_ms",
            "train_minutes", "front"]
    if seeds > 1:
        for t in table:
            t[QUALITY + " runs"] = " / ".join("-" if v is None else f"{v:.2f}"
                                              for v in t.get("seed_runs", {}).get(QUALITY, []))
        cols.insert(3, QUALITY + " runs")
    over = f", means over {seeds} seeds" if seeds > 1 else ""
    return (f"# Speed against accuracy ({result.preset} sweep, {result.scene} scene{over})\n\n"
            + markdown_table(table, cols)
            + f"\nfps at {fps_size}x{fps_size} end to end (int8 unless the point is fp32); "
              f"PSNR in dB on the hold-out sequence; temporal = flicker (lower is better)"
            + (f"; quality, fps and training minutes are means over {seeds} trainings with seeds "
               "base, base + 1, ... (the seed axis's points are single trainings)" if seeds > 1 else "") + ".\n\n"
            + (f"The base point over {len(noise['points'])} seeds spans {noise['range_db']:.2f} dB of {QUALITY} "
               f"(std {noise['std_db']:.2f} dB): differences smaller than that are within training noise; "
               "the seed points stay off the fronts.\n\n" if noise else "")
            + f"RGB floor (no learning, `{Path(floor.run).name}`): {floor.metric(QUALITY):.2f} dB {QUALITY} on the "
              "same hold-out; its speed is not measured, so the charts draw it as a horizontal line.\n\n"
            + f"{PAPER_NOTE}\n")


def _measure_rows(project, sweep, todo, seeds: int, model, out: Path, ray, workers, cpus_per_task
                  ) -> tuple[list[PointRow], list[str]]:
    """Measure the (SweepPoint, TrainConfig) pairs ``todo`` and, with ``seeds`` > 1, their seed
    repeats: (rows in ``todo``'s order, with their seed means; names of the points reused from
    saved results)."""
    from morf.sizing.sweep import NOISE_AXES

    repeats = seed_repeats(todo, seeds) if seeds > 1 else {}
    measured = measure_points(project, sweep, todo + [pc for pcs in repeats.values() for pc in pcs], model, out,
                              ray, workers, cpus_per_task)
    rows = [measured[p.name][0] for p, _ in todo]
    reused = [p.name for p, _ in todo if measured[p.name][1]]
    for i, row in enumerate(rows):
        print(f"[{i + 1}/{len(rows)}] {row.name}: {QUALITY} {row.metric(QUALITY)}, fps {row.fps}, "
              f"train {row.evaluation.train_minutes} min" + (" (saved result)" if row.name in reused else ""))
    shutil.rmtree(out / "work", ignore_errors=True)  # exports made only to time playback
    if seeds > 1:  # the seed points re-measure the base: they stay single trainings
        rows = [r if r.axis in NOISE_AXES else with_seeds(r, [measured[p.name][0] for p, _ in repeats[r.name]])
                for r in rows]
    return rows, reused


def run_sweep(out, preset: str = "default", scene: str = "print", project_path: str | None = None,
              axes: list[str] | None = None, model=None, extra: list | None = None,
              points: list[str] | None = None, project=None, seeds: int = 1, ray=None,
              workers: int | None = None, cpus_per_task: int | None = None) -> SweepResult:
    """Run (or resume) one sweep and write its JSON, Markdown and charts; returns the result.

    ``points`` names the points to measure (all of ``axes`` when None); the other points of
    ``axes`` already measured in ``OUT`` on the same capture join the result as saved, so a sweep
    grows point by point. ``extra``: (SweepPoint, TrainConfig) pairs measured beside the sweep's
    own points (the automatic choice in ``--auto-check``). ``project``: the opened capture, when
    the caller has it (else made or opened from ``project_path``). ``seeds`` > 1: every point
    (seed-axis points aside) is trained that many times (:func:`seed_repeats`); each row then
    carries ``seed_runs`` and ``seed_means`` of :data:`SEED_KEYS` (:func:`with_seeds`), and fronts, charts and table
    use the means. ``ray`` (RayOptions), ``workers``, ``cpus_per_task``: where and how the
    trainings run (:func:`train_all`).
    """
    from morf.bench.common import machine_info, write_results
    from morf.errors import InputError
    from morf.scale.ray_runtime import RayOptions
    from morf.presets import preset as named_preset
    from morf.sizing.sweep import NOISE_AXES, resolve, select

    if seeds < 1:
        raise InputError(f"seeds must be at least 1, got {seeds}")
    out = Path(out)
    sweep = named_preset("sweep", preset)
    if model is None:
        from morf.body import load_body_model

        model = load_body_model("anny")
    if project is None:
        project = make_capture(out, sweep, scene, model, project_path)
    named = select(sweep, axes, points)
    todo = [(p, None) for p in select(sweep, axes) if p in named or saved_point(out, sweep, p, project)]
    todo = [(p, cfg or resolve(sweep, p)) for p, cfg in todo + list(extra or [])]
    rows, reused = _measure_rows(project, sweep, todo, seeds, model, out, ray, workers, cpus_per_task)
    rows, front, sized = _mark_fronts(rows)
    view = [{**r.to_dict(), **(r.seed_means or {})} for r in (rows[i] for i in sized)]  # what charts and table show
    noise = seed_spread(rows)
    floor = floor_point(project, sweep, model)
    over = f", means over {seeds} seeds" if seeds > 1 else ""
    drawn = charts(view, front, out, sweep.fps_size, f"{preset} sweep, {scene} scene{over}", noise, floor)
    result = SweepResult(preset, scene, str(project.root), sweep.fps_size, tuple(rows), noise, tuple(reused), seeds,
                         floor, {"address": (ray or RayOptions()).where,
                                 "cpus_per_task": cpus_per_task or os.cpu_count()}, machine_info(), tuple(drawn))
    shown = view + [r.to_dict() for r in rows if r.axis in NOISE_AXES]
    path = write_results(out, "pareto", result.to_dict(), _markdown(result, shown, sweep.fps_size))
    print(f"wrote {path}")
    return result
