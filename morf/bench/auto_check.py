"""``morf bench pareto --auto-check``: does ``--preset auto`` pick sizes on or near the front?

For each synthetic scene (plain clothing, high-frequency print, loose garment) the automatic
choice is made from the capture, trained and measured beside the sweep's sizing points
(renderer, texture resolution, channels). It passes on a scene when no sweep point is more than
``SizingRule.quality_margin_db`` better on the person's PSNR while at most
``SizingRule.fps_margin_frac`` slower (the fps measurement's noise) or faster, nor more than that
share faster while at most the quality margin worse or better
(:func:`morf.bench.front.near_front`). Writes ``OUT/auto_check.json`` and ``OUT/auto_check.md``;
each scene's sweep is in ``OUT/<scene>/`` (resumable like any sweep).

One training per point resolves about 1 dB at default size, coarser than the margin; with
``seeds`` > 1 every point (the automatic choice included) is trained again with further seeds
(``OUT/<scene>/points/<name>-seed<k>.json``) and the verdict compares the means. Each scene's row
then also says whether the verdict is beyond that noise: the gap to the best point at most the fps
margin slower, with its standard error over the seeds (:func:`morf.bench.front.quality_gap`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from morf.bench.pareto_results import QUALITY

SIZING_AXES = ["renderer", "texture_size", "texture_channels"]
SCENE_ORDER = ("plain", "print", "loose")


@dataclass(frozen=True)
class SceneVerdict:
    """One scene's row of ``auto_check.json``'s "table".

    Fields:
        scene; texture_size, texture_channels, renderer_width, params_M: the automatic choice;
        quality: its :data:`QUALITY` (mean over the seeds); best_quality: the best point's;
        fps: its playback speed; near_front: the verdict (:func:`morf.bench.front.near_front`);
        gap_db, gap_se_db: the best point at most the fps margin slower minus the choice, and its
            standard error over the seeds (:func:`morf.bench.front.quality_gap`; None where it has none);
        beyond_noise: the gap is more than two standard errors from the quality margin (None with one seed).
    """

    scene: str
    texture_size: int
    texture_channels: int
    renderer_width: int
    params_M: float
    quality: float | None
    best_quality: float | None
    fps: float | None
    near_front: bool
    gap_db: float | None
    gap_se_db: float | None
    beyond_noise: bool | None

    def to_dict(self) -> dict:
        return {"scene": self.scene, "texture_size": self.texture_size, "texture_channels": self.texture_channels,
                "renderer_width": self.renderer_width, "params_M": self.params_M, QUALITY: self.quality,
                "best_" + QUALITY: self.best_quality, "fps": self.fps, "near_front": self.near_front,
                "gap_db": self.gap_db, "gap_se_db": self.gap_se_db, "beyond_noise": self.beyond_noise}


def scene_projects(scenes, project_path: str | dict | None) -> dict[str, str | None]:
    """Each scene's existing capture (None: made in ``OUT/<scene>``).

    ``project_path`` is a path (exactly one scene), ``{scene: path}``, or its command-line form
    ``scene=PATH[,scene=PATH...]``; scenes not named get a capture of their own.
    """
    from morf.errors import InputError

    if project_path is None:
        return {s: None for s in scenes}
    if isinstance(project_path, str) and "=" not in project_path:
        if len(scenes) != 1:
            raise InputError("--project PATH with --auto-check needs exactly one scene (--scenes), "
                             "or name the scene: --project print=PATH")
        return {scenes[0]: project_path}
    if isinstance(project_path, str):
        pairs = [kv.split("=", 1) for kv in project_path.split(",") if kv.strip()]
        if any(len(kv) != 2 or not kv[1].strip() for kv in pairs):
            raise InputError(f"--project {project_path!r}: expected scene=PATH[,scene=PATH...]")
        project_path = {k.strip(): v.strip() for k, v in pairs}
    extra = sorted(set(project_path) - set(scenes))
    if extra:
        raise InputError(f"--project names scenes {extra} that are not checked (--scenes {','.join(scenes)})")
    return {s: project_path.get(s) for s in scenes}


def _runs_text(vals: list) -> str:
    return " / ".join("diverged" if v is None else f"{v:.2f}" for v in vals)


def _check_scene(out: Path, preset: str, sweep, scene: str, project_path: str | None, model, rule,
                 points: list[str] | None, seeds: int, ray=None) -> tuple[SceneVerdict, dict]:
    """One scene: the automatic choice made from its capture, measured beside the sizing points
    (:func:`morf.bench.pareto.run_sweep` in ``OUT/<scene>``), and judged; (its row, its details)."""
    from morf.bench.front import near_front, quality_gap
    from morf.bench.pareto import make_capture, run_sweep
    from morf.sizing.choose import choose_train_config
    from morf.sizing.sweep import SweepPoint

    project = make_capture(out / scene, sweep, scene, model, project_path)
    name, overrides = sweep.train
    cfg, reasons = choose_train_config(project, name, model=model, rule=rule, **overrides)
    # Same training as an identical sweep point (the preset name is only a label).
    cfg = cfg.replace(preset=sweep.train[0])
    res = run_sweep(out / scene, preset, scene, axes=SIZING_AXES, model=model, extra=[(SweepPoint("auto", "auto"), cfg)],
                    points=points, project=project, seeds=seeds, ray=ray)
    rows_by_name = {r.name: r for r in res.points}
    means = {n: [r.mean(QUALITY), r.mean("fps")] for n, r in rows_by_name.items()}
    q_auto, fps_auto = means["auto"]
    vals = [[float("nan") if v is None else v for v in m] for m in means.values()]
    fps_margin = rule.fps_margin_frac * fps_auto if fps_auto is not None else 0.0
    ok = near_front(vals, list(means).index("auto"), (rule.quality_margin_db, fps_margin))
    best = max((q for q, _ in means.values() if q is not None), default=None)
    runs = {n: r.seed_runs[QUALITY] if r.seed_runs is not None else [r.metric(QUALITY)]
            for n, r in rows_by_name.items()}
    gap, se, rival = quality_gap(runs, {n: f for n, (_, f) in means.items()}, "auto", fps_margin)
    a = rows_by_name["auto"]
    verdict = SceneVerdict(scene, cfg.texture_size, cfg.texture_channels, cfg.renderer.width,
                           a.evaluation.params / 1e6, q_auto, best, fps_auto, ok, gap, se,
                           None if se is None else abs(gap - rule.quality_margin_db) > 2 * se)
    details = {"reasons": reasons, "config": a.config, "point": a.to_dict(), "near_front": ok, "rival": rival}
    if seeds > 1:
        details["means"] = {n: {QUALITY: q, "fps": f, QUALITY + "_runs": runs[n]} for n, (q, f) in means.items()}
    print(f"{scene}: texture {cfg.texture_size}, channels {cfg.texture_channels}, renderer width "
          f"{cfg.renderer.width}; near the front: {ok}")
    return verdict, details


def _markdown(rule, seeds: int, table: list[dict], details: dict) -> str:
    from morf.bench.common import markdown_table

    over = f"; means over {seeds} seeds per point" if seeds > 1 else ""
    md = ("# Automatic size choice against the sweep\n\n"
          f"near_front: no sweep point is more than {rule.quality_margin_db} dB better at most "
          f"{rule.fps_margin_frac:.0%} slower, nor more than {rule.fps_margin_frac:.0%} faster at most "
          f"{rule.quality_margin_db} dB worse ({QUALITY}{over}). gap_db: the best point at most "
          f"{rule.fps_margin_frac:.0%} slower minus the automatic choice; gap_se_db: its standard error over "
          f"the seeds; beyond_noise: the gap is more than two standard errors from the {rule.quality_margin_db} dB "
          "margin (the verdict would survive more seeds; empty with one seed).\n\n")
    md += markdown_table(table, list(table[0])) if table else ""
    for scene, d in details.items():
        md += f"\n## {scene}\n\n" + "\n".join(f"- {r}" for r in d["reasons"]) + "\n"
        if "means" in d:
            md += "\n" + "".join(f"- {n}: {_runs_text(m[QUALITY + '_runs'])} dB\n" for n, m in d["means"].items())
    return md


def auto_check(out: Path, preset: str = "quick", model=None, scenes=SCENE_ORDER,
               project_path: str | dict | None = None, points: list[str] | None = None, seeds: int = 1,
               ray=None) -> dict:
    """Run the check on ``scenes``; returns the summary written to ``OUT/auto_check.json``.

    ``project_path``: existing synthetic captures to use instead of making them
    (see :func:`scene_projects`); ``points``: only these sweep points beside the automatic choice
    (names as in ``--points``); ``seeds``: trainings per point, the verdict on their means;
    ``ray`` (RayOptions): where the scenes' sweeps train (:func:`morf.bench.pareto.run_sweep`).
    """
    from morf.bench.common import machine_info, write_results
    from morf.errors import InputError
    from morf.presets import preset as named_preset
    from morf.sizing.choose import SizingRule

    unknown = [s for s in scenes if s not in SCENE_ORDER]
    if unknown:
        raise InputError(f"unknown scenes {unknown}; choose from {', '.join(SCENE_ORDER)}")
    if seeds < 1:
        raise InputError(f"seeds must be at least 1, got {seeds}")
    projects = scene_projects(list(scenes), project_path)
    out = Path(out)
    sweep = named_preset("sweep", preset)
    rule = SizingRule()
    if model is None:
        from morf.body import load_body_model

        model = load_body_model("anny")
    rows, details = [], {}
    for scene in scenes:
        row, details[scene] = _check_scene(out, preset, sweep, scene, projects[scene], model, rule, points, seeds,
                                              ray)
        rows.append(row)
    distinct = len({(r.texture_size, r.texture_channels, r.renderer_width) for r in rows})
    table = [r.to_dict() for r in rows]
    summary = {"benchmark": "auto_check", "preset": preset, "seeds": seeds, "margin_db": rule.quality_margin_db,
               "rule": rule.__dict__, "scenes": details, "table": table, "distinct_choices": distinct,
               "all_near_front": all(r.near_front for r in rows), "machine": machine_info()}
    write_results(out, "auto_check", summary, _markdown(rule, seeds, table, details))
    return summary
