"""``morf bench pareto --auto-check``: does ``--preset auto`` pick sizes on or near the front?

For each synthetic scene (plain clothing, high-frequency print, loose garment) the automatic
choice is made from the capture, trained and measured beside the sweep's sizing points
(renderer, texture resolution, channels). It passes on a scene when no sweep point is at least
as fast and more than ``SizingRule.quality_margin_db`` better on the person's PSNR, or as good and
more than ``SizingRule.fps_margin_frac`` faster (the fps measurement's noise)
(:func:`morf.sizing.front.near_front`). Writes ``OUT/auto_check.json`` and ``OUT/auto_check.md``;
each scene's sweep is in ``OUT/<scene>/`` (resumable like any sweep).
"""

from __future__ import annotations

from pathlib import Path

SIZING_AXES = ["renderer", "texture_size", "texture_channels"]
SCENE_ORDER = ("plain", "print", "loose")


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


def auto_check(out: Path, preset: str = "quick", model=None, scenes=SCENE_ORDER,
               project_path: str | dict | None = None, points: list[str] | None = None) -> dict:
    """Run the check on ``scenes``; returns the summary written to ``OUT/auto_check.json``.

    ``project_path``: existing synthetic captures to use instead of making them
    (see :func:`scene_projects`); ``points``: only these sweep points beside the automatic choice
    (names as in ``--points``).
    """
    from morf.bench.common import machine_info, markdown_table, write_results
    from morf.bench.pareto import QUALITY, make_capture, run_sweep
    from morf.errors import InputError
    from morf.sizing.choose import SizingRule, choose_train_config
    from morf.sizing.front import near_front
    from morf.sizing.sweep import PRESETS, SweepPoint

    unknown = [s for s in scenes if s not in SCENE_ORDER]
    if unknown:
        raise InputError(f"unknown scenes {unknown}; choose from {', '.join(SCENE_ORDER)}")
    projects = scene_projects(list(scenes), project_path)

    out = Path(out)
    sweep = PRESETS[preset]
    rule = SizingRule()
    if model is None:
        from morf.body import load_body_model

        model = load_body_model("anny")
    rows, details = [], {}
    for scene in scenes:
        project = make_capture(out / scene, sweep, scene, model, projects[scene])
        name, overrides = sweep.train
        cfg, reasons = choose_train_config(project, name, model=model, rule=rule, **overrides)
        # Same training as an identical sweep point (the preset name is only a label).
        cfg = cfg.replace(preset=sweep.train[0])
        auto = SweepPoint("auto", "auto")
        res = run_sweep(out / scene, preset, scene, axes=SIZING_AXES, model=model, extra=[(auto, cfg)],
                        points=points, project=project)
        pts = res["points"]
        i = next(k for k, p in enumerate(pts) if p["name"] == "auto")
        vals = [[p.get(QUALITY), p.get("fps")] for p in pts]
        vals = [[float("nan") if v is None else v for v in pair] for pair in vals]
        fps_margin = rule.fps_margin_frac * vals[i][1] if vals[i][1] == vals[i][1] else 0.0  # NaN-safe
        ok = near_front(vals, i, (rule.quality_margin_db, fps_margin))
        best = max((p[QUALITY] for p in pts if p.get(QUALITY) is not None), default=None)
        a = pts[i]
        rows.append({"scene": scene, "texture_size": cfg.texture_size, "texture_channels": cfg.texture_channels,
                     "renderer_width": cfg.renderer.width, "params_M": a["params"] / 1e6, QUALITY: a.get(QUALITY),
                     "best_" + QUALITY: best, "fps": a.get("fps"), "near_front": ok})
        details[scene] = {"reasons": reasons, "config": a["config"], "point": a, "near_front": ok}
        print(f"{scene}: texture {cfg.texture_size}, channels {cfg.texture_channels}, renderer width "
              f"{cfg.renderer.width}; near the front: {ok}")
    distinct = len({(r["texture_size"], r["texture_channels"], r["renderer_width"]) for r in rows})
    summary = {"benchmark": "auto_check", "preset": preset, "margin_db": rule.quality_margin_db,
               "rule": rule.__dict__, "scenes": details, "table": rows, "distinct_choices": distinct,
               "all_near_front": all(r["near_front"] for r in rows), "machine": machine_info()}
    md = ("# Automatic size choice against the sweep\n\n"
          f"near_front: no sweep point is as fast and more than {rule.quality_margin_db} dB better, or as good "
          f"and more than {rule.fps_margin_frac:.0%} faster "
          f"({QUALITY}).\n\n" + markdown_table(rows, list(rows[0])) if rows else "")
    md += "".join(f"\n## {s}\n\n" + "\n".join(f"- {r}" for r in d["reasons"]) + "\n" for s, d in details.items())
    write_results(out, "auto_check", summary, md)
    return summary
