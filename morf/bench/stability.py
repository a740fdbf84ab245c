"""``morf bench stability --out DIR [--preset tiny|default]``: quality as one nuisance grows.

Stress series, each a family of synthetic captures with one nuisance turned up step by step from
a clean capture (no sliding, tight clothes, exact keypoints):

* misalignment: Gaussian noise (degrees, per axis-angle component of every bone) added to the
  true poses the avatar is trained on;
* slide: cloth sliding over the body (texture-space drift, atlas units);
* loose: garments standing off the body (metres at the hem and cuffs);
* fast: the same turn in fewer frames (speed-up factor);
* keypoints: keypoint noise (pixels at 512 px) and corrupted frames together; these captures are
  fitted (``morf fit``'s code, the stability preset's fit preset) and trained on the fits;
* coverage: degrees of the turn never shown (frames facing further than 180 - x/2 degrees from
  the camera are dropped; 180 = the back is never seen);
* views (fit only, no training: :mod:`morf.bench.stability_views`): the turn kept as 8 to 24
  views, fitted and scored by root error, pelvis-shoulder twist and vertex error against the
  truth and against the whole capture's fit; ``DIR/stability_views.png``.

For morf, stylepeople and anr: hold-out PSNR / SSIM (image and person) and temporal flicker per
level, and whether training diverged (TrainingDiverged or NaN metrics). A method *breaks down* at
the first level where its person-PSNR falls more than ``BREAKDOWN_DB`` below its level-0 value,
or where it diverges. ``--repeats N`` trains every (series, level, method) N times with seeds
0..N-1: a level's metrics are then the means over the repeats that did not diverge (with the
person-PSNR's min and max), it counts as diverged when any repeat did, and the breakdown
threshold grows to twice the measured run-to-run spread (pooled standard deviation of the
repeats) when that is larger than ``BREAKDOWN_DB``. Writes ``DIR/stability.json``, ``DIR/stability.md``,
``DIR/stability_psnr.png`` and ``DIR/stability_temporal.png``; every (series, level, method)
result is kept in ``DIR/points/`` (``<series>-<level index>-<method>[-seed<r>].json``) and reused
on a re-run.

The trainings run as Ray tasks (:mod:`morf.scale`; a local Ray by default, a cluster with
``--address``), ``--cpus-per-task`` cores each (default 1). Levels that train on their own capture
all run at once; the levels that train on the shared clean capture with its frames dropped
(coverage) or noisy fits written into it (misalignment) run in waves, one setting of the clean
capture at a time (:func:`plan_waves`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from morf.bench.stability_rows import LevelRepeats, StabilityPoint

if TYPE_CHECKING:
    from morf.presets.stability import StabilityPreset  # the presets: stage "stability" of morf.presets

METHODS = ("morf", "stylepeople", "anr")
SERIES = ("misalignment", "slide", "loose", "fast", "keypoints", "coverage")  # trained and scored on the hold-out
FIT_SERIES = ("views",)  # fitted and scored against the true poses
LABELS = {"misalignment": "pose noise (deg)", "slide": "sliding (atlas units)", "loose": "looseness (m)",
          "fast": "speed-up (x fewer frames)", "keypoints": "kp noise (px @512) + corrupt share / 100",
          "coverage": "degrees of the turn never shown"}
BREAKDOWN_DB = 1.0  # about the run-to-run noise of one training (docs/avatar.md); a larger drop is real
CLEAN = {"slide": 0.0, "loose": 0.0, "kp_noise": 0.0, "corrupt": 0.0}


# ---- captures and training inputs per (series, level) ---------------------------------------
def _capture(out: Path, name: str, sp: StabilityPreset, model, **changes):
    from morf.capture.project import CaptureProject
    from morf.synth import make_synthetic_capture, synth_config
    from morf.synth.ground_truth import has_holdout

    root = out / "captures" / name
    if CaptureProject.is_project(root) and has_holdout(root):
        return CaptureProject.open(root)
    preset, overrides = sp.synth
    cfg = synth_config(preset, **{**overrides, **CLEAN, **changes})
    print(f"making capture {name}")
    return make_synthetic_capture(root, cfg, model=model, overwrite=True)


def _write_noisy_fits(project, sigma_deg: float, seed: int) -> None:
    """fits/fits.npz = the true poses plus Gaussian noise on every bone's axis-angle."""
    from morf.fitting.fits_io import BodyFits, save_fits
    from morf.synth.ground_truth import load_ground_truth

    gt = load_ground_truth(project)
    rng = np.random.default_rng(seed)
    rot = gt.rotvecs + rng.normal(0, np.deg2rad(sigma_deg), gt.rotvecs.shape).astype(np.float32)
    n = len(rot)
    nan = np.full(n, np.nan, np.float32)
    save_fits(project.fits_path, BodyFits(rot, gt.transl, gt.shape, nan, nan, nan,
                                          np.zeros((n, 23, 2), np.float32), {"synthetic_noise_deg": sigma_deg}))


def _set_hidden_turn(root: Path, hidden_deg: float) -> None:
    """Drop (review.json) the frames facing more than 180 - hidden/2 degrees away from the camera;
    0 clears the drops. The shared clean capture is set this way before each of its trainings."""
    from morf.io import atomic_write_json
    from morf.synth.ground_truth import load_ground_truth

    yaw = load_ground_truth(root, require=("yaw",)).yaw
    away = np.abs((np.degrees(yaw) + 180) % 360 - 180)
    drop = [int(i) for i in np.flatnonzero(away > 180 - hidden_deg / 2)] if hidden_deg > 0 else []
    atomic_write_json(Path(root) / "review.json", {"drop": drop, "keep": []})


def _fit(project, sp: StabilityPreset, model) -> None:
    from morf.fitting.project_fit import fit_progress, fit_project
    from morf.presets import preset as named_preset

    if fit_progress(project).complete:  # every output on disk, not only fits.npz (a fit killed midway resumes)
        return
    fit_project(project, named_preset("fit", sp.fit).replace(overlays=False), model=model)


@dataclass(frozen=True)
class Setting:
    """What one (series, level) trains on.

    Fields:
        project: the capture's folder; fits_source: ground-truth | fits; stem: the run names' stem.
        hidden_deg: degrees of the turn dropped from the shared clean capture (its review.json)
            while this trains; None for a capture of its own, which nothing else changes.
        noise: (degrees, seed) of the noisy fits written into the clean capture for this training.
    """

    project: str
    fits_source: str
    stem: str
    hidden_deg: float | None = None
    noise: tuple[float, int] | None = None


def prepare(series: str, i: int, level, out: Path, sp: StabilityPreset, model) -> Setting:
    """The setting of one level, its capture made (and fitted) if missing; level 0 of the
    synthetic-nuisance series is the shared clean capture trained on its true poses. The clean
    capture itself is changed only by :func:`apply_setting`, just before its trainings run."""
    base = _capture(out, "clean", sp, model)
    clean = lambda fits, stem, hidden=0, noise=None: Setting(str(base.root), fits, stem, hidden, noise)  # noqa: E731
    if series == "keypoints":
        p = _capture(out, f"keypoints-{i}", sp, model, kp_noise=level * sp_size(sp) / 512, corrupt=level / 100)
        _fit(p, sp, model)
        return Setting(str(p.root), "fits", f"stab-keypoints-{i}")
    if i == 0:  # every series but "keypoints" starts from the clean capture and its true poses
        return clean("ground-truth", "stab-clean")
    if series == "misalignment":
        return clean("fits", f"stab-misalignment-{i}", noise=(float(level), i))
    if series == "coverage":
        return clean("ground-truth", f"stab-coverage-{i}", hidden=level)
    if series == "fast":
        frames = max(4, int(round(sp_frames(sp) / level)))
        fast = _capture(out, f"fast-{i}", sp, model, frames=frames)
        return Setting(str(fast.root), "ground-truth", f"stab-fast-{i}")
    return Setting(str(_capture(out, f"{series}-{i}", sp, model, **{series: level}).root), "ground-truth",
                   f"stab-{series}-{i}")


def apply_setting(hidden_deg: float, noise: tuple[float, int] | None, clean_root: str) -> None:
    """Set the shared clean capture up for a wave: the hidden turn in review.json, and the noisy
    fits when the wave trains on them."""
    from morf.capture.project import CaptureProject

    _set_hidden_turn(Path(clean_root), hidden_deg)
    if noise is not None:
        _write_noisy_fits(CaptureProject.open(clean_root), noise[0], seed=noise[1])


def plan_waves(settings: list[Setting]) -> list[tuple[float | None, tuple | None, list[int]]]:
    """Group trainings into waves that can run at once: [(hidden_deg, noise, indices)], in the
    order the settings first appear. Trainings on captures of their own join the first wave; those
    on the clean capture share a wave when they hide the same turn and need the same noisy fits
    (a training on the true poses reads no fits, so it joins any wave with its hidden turn)."""
    waves: list[list] = []
    for k, st in enumerate(settings):
        if st.hidden_deg is None:
            if not waves:
                waves.append([None, None, []])
            waves[0][2].append(k)
            continue
        noise = st.noise if st.fits_source == "fits" else None
        for w in waves:
            if w[0] is None:  # the first wave held only captures of their own: it takes this setting
                w[0] = st.hidden_deg
            if w[0] == st.hidden_deg and (noise is None or w[1] is None or w[1] == noise):
                w[1] = noise or w[1]
                w[2].append(k)
                break
        else:
            waves.append([st.hidden_deg, noise, [k]])
    return [(h, n, idx) for h, n, idx in waves]


def sp_size(sp: StabilityPreset) -> int:
    from morf.synth.config import synth_config

    return synth_config(sp.synth[0], **sp.synth[1]).size


def sp_frames(sp: StabilityPreset) -> int:
    from morf.synth.config import synth_config

    return synth_config(sp.synth[0], **sp.synth[1]).frames


# ---- the benchmark ----------------------------------------------------------------------------
METRICS = ("psnr", "ssim", "psnr_person", "ssim_person", "temporal", "train_minutes")


def combine_repeats(runs: list[StabilityPoint]) -> LevelRepeats:
    """One level's row from its repeats: metric means over the runs that did not diverge, the
    person-PSNR's min / max / sample standard deviation, ``diverged`` when any run diverged."""
    ok = [r.evaluation for r in runs if not r.diverged and r.psnr_person is not None]
    means = {}
    for k in METRICS:
        vals = [getattr(e, k) for e in ok if getattr(e, k) is not None]
        means[k] = float(np.mean(vals)) if vals else None
    person = [e.psnr_person for e in ok]
    first = runs[0]
    return LevelRepeats(first.series, first.level, first.method, first.seed, first.evaluation.params,
                        len(ok) < len(runs), **means, repeats=len(runs), diverged_runs=len(runs) - len(ok),
                        psnr_person_min=min(person) if person else None,
                        psnr_person_max=max(person) if person else None,
                        psnr_person_std=float(np.std(person, ddof=1)) if len(person) > 1 else None,
                        runs=tuple(r.evaluation.run for r in runs), background=first.evaluation.background,
                        frames=first.evaluation.frames, eval_resolution=first.evaluation.eval_resolution)


def breakdown_threshold(rows: list[StabilityPoint | LevelRepeats]) -> float:
    """BREAKDOWN_DB, or twice the pooled run-to-run standard deviation of the person-PSNR over the
    levels that were repeated, whichever is larger."""
    var = [r.psnr_person_std ** 2 for r in rows if isinstance(r, LevelRepeats) and r.psnr_person_std is not None]
    return max(BREAKDOWN_DB, 2.0 * float(np.sqrt(np.mean(var)))) if var else BREAKDOWN_DB


def breaks_down_at(levels: list, rows: list[StabilityPoint | LevelRepeats], threshold: float = BREAKDOWN_DB) -> object:
    """First level whose person-PSNR is more than ``threshold`` dB below level 0's, or that diverged."""
    ref = rows[0].psnr_person if rows else None
    for lv, r in zip(levels, rows):
        if r.diverged or r.psnr_person is None:
            return lv
        if ref is not None and r.psnr_person < ref - threshold:
            return lv
    return None


def _point_path(out: Path, series: str, i: int, method: str, r: int) -> Path:
    return out / "points" / f"{series}-{i}-{method}{f'-seed{r}' if r else ''}.json"


def _train_missing(out: Path, sp: StabilityPreset, series, methods, repeats: int, model, ray, workers,
                   cpus_per_task) -> None:
    """Train and score every (series, level, method, seed) without a saved result, in the waves
    of :func:`plan_waves`, saving each result as its wave ends; raises TasksFailed at the end when
    some trainings failed (the others' results are saved)."""
    from morf.bench.pareto import Training, train_all
    from morf.io import atomic_write_json
    from morf.scale.tasks import Outcome, TasksFailed
    from morf.train.config import preset as train_preset

    jobs = []  # (result path, (series, level, method, seed), Training, Setting)
    for s in series:
        for i, level in enumerate(sp.levels[s]):
            missing = [(m, r, _point_path(out, s, i, m, r)) for m in methods for r in range(repeats)]
            missing = [(m, r, path) for m, r, path in missing if not path.is_file()]
            if not missing:
                continue
            st = prepare(s, i, level, out, sp, model)  # once a level: it opens (or makes) the capture
            for m, r, path in missing:
                cfg = train_preset(sp.train[0], m, **sp.train[1]).replace(seed=r)
                tag = f"-seed{r}" if r else ""
                jobs.append((path, (s, level, m, r),
                             Training(str(Path(st.project).resolve()), cfg, f"{st.stem}-{m}{tag}",
                                      st.fits_source), st))
    failed = []
    clean = str(out / "captures" / "clean")
    for hidden, noise, idx in plan_waves([j[3] for j in jobs]):
        if hidden is not None:
            apply_setting(hidden, noise, clean)
        setup = "" if hidden is None else (f" (clean capture: {hidden:g} degrees hidden"
                                           f"{', noisy fits' if noise else ''})")
        print(f"wave: {len(idx)} training{'s' if len(idx) > 1 else ''}{setup}")
        trained = train_all([jobs[k][2] for k in idx], ray, workers, cpus_per_task or 1)
        for k in idx:
            path, head, t, _ = jobs[k]
            o = trained[(t.root, t.run)]
            if o.ok:
                atomic_write_json(path, StabilityPoint(*head, o.value).to_dict())
            else:
                failed.append(Outcome(path.stem, error=o.error))
    if (Path(clean) / "review.json").is_file():
        _set_hidden_turn(Path(clean), 0)  # leave the clean capture with every frame used
    if failed:
        raise TasksFailed("trainings", failed)


def _series_results(out: Path, sp: StabilityPreset, series: list[str], methods: list[str],
                    repeats: int) -> tuple[dict, list[dict]]:
    """The saved points as stability.json's "series" (levels, rows per method, breakdown
    thresholds and levels) and the Markdown table's rows."""
    result_series, md_rows = {}, []
    for s in series:
        levels = sp.levels[s]
        per_method = {m: [] for m in methods}
        for i, level in enumerate(levels):
            for m in methods:
                runs = [StabilityPoint.from_dict(json.loads(_point_path(out, s, i, m, r).read_text()))
                        for r in range(repeats)]
                row = combine_repeats(runs) if repeats > 1 else runs[0]
                per_method[m].append(row)
                md_rows.append({"series": s, "level": level, "method": m, **row.to_dict()})
        thresholds = {m: breakdown_threshold(per_method[m]) for m in methods}
        result_series[s] = {"label": LABELS[s], "levels": levels,
                            "methods": {m: [r.to_dict() for r in rows] for m, rows in per_method.items()},
                            "threshold_db": thresholds,
                            "breaks_down_at": {m: breaks_down_at(levels, per_method[m], thresholds[m])
                                               for m in methods}}
    return result_series, md_rows


def _breakdown_rule(repeats: int) -> str:
    if repeats > 1:
        return (f"mean person-PSNR over {repeats} seeds more than max({BREAKDOWN_DB} dB, twice the pooled "
                "run-to-run standard deviation) below the method's level-0 mean, or a training diverged")
    return (f"person-PSNR more than {BREAKDOWN_DB} dB below the method's level-0 value, "
            "or training diverged (TrainingDiverged / NaN)")


def _charts(result_series: dict, out: Path, preset: str) -> list[str]:
    from morf.bench.charts import series_chart

    if not result_series:
        return []
    return [str(series_chart(result_series, "psnr_person", out / "stability_psnr.png",
                             title=f"Hold-out PSNR on the person as nuisances grow ({preset})",
                             ylabel="PSNR person (dB)")),
            str(series_chart(result_series, "temporal", out / "stability_temporal.png",
                             title=f"Temporal flicker as nuisances grow ({preset}; lower is better)",
                             ylabel="flicker"))]


def _markdown(result: dict, md_rows: list[dict], views: dict | None) -> str:
    from morf.bench.common import markdown_table

    methods, repeats = result["methods"], result["repeats"]
    brk = [{"series": s, **{m: v["breaks_down_at"][m] for m in methods},
            **{f"{m} threshold dB": v["threshold_db"][m] for m in methods}} for s, v in result["series"].items()]
    cols = ["series", "level", "method", "psnr_person", "ssim_person", "psnr", "temporal", "diverged", "train_minutes"]
    if repeats > 1:
        cols[4:4] = ["psnr_person_min", "psnr_person_max", "psnr_person_std"]
        cols.insert(-1, "diverged_runs")
    md = (f"# Stability under nuisances ({result['preset']})\n\nBreaks down = {result['breakdown_rule']}; "
          "n/a = never within the levels tried.\n\n"
          + markdown_table(brk, ["series", *methods] + ([f"{m} threshold dB" for m in methods] if repeats > 1 else []))
          + "\n" + markdown_table(md_rows, cols))
    if views is not None:
        from morf.bench.stability_views import COLUMNS, views_table_rows

        md += (f"\n\n## Fit only: the turn in a few views (fit preset {views['fit_preset']})\n\n"
               "Root error and vertex error against the true poses; twist: the fitted body's worst "
               "pelvis-shoulder twist; twisted_caught: twisted frames the frame filter rejected.\n\n"
               + markdown_table(views_table_rows(views), COLUMNS))
    return md


def run_stability(out, preset: str = "default", series: list[str] | None = None, methods: list[str] | None = None,
                  model=None, repeats: int = 1, ray=None, workers: int | None = None,
                  cpus_per_task: int | None = None) -> dict:
    """Run (or resume) the stress series; writes JSON, Markdown and charts; returns the result.
    ``ray`` (RayOptions), ``workers``, ``cpus_per_task`` (default 1): where and how the trainings
    run (:func:`morf.bench.pareto.train_all`)."""
    from morf.bench.common import machine_info, write_results
    from morf.errors import InputError
    from morf.presets import preset as named_preset
    from morf.scale.ray_runtime import RayOptions

    out = Path(out)
    sp = named_preset("stability", preset)
    series = series or list(SERIES + FIT_SERIES)
    methods = methods or list(METHODS)
    bad = [s for s in series if s not in SERIES + FIT_SERIES] + [m for m in methods if m not in METHODS]
    if bad:
        raise InputError(f"unknown series or methods: {', '.join(bad)}")
    if repeats < 1:
        raise InputError("--repeats must be at least 1")
    if model is None:
        from morf.body import load_body_model

        model = load_body_model("anny")
    views = _views_series(out, sp, model, preset) if "views" in series else None
    series = [s for s in series if s in SERIES]
    _train_missing(out, sp, series, methods, repeats, model, ray, workers, cpus_per_task)
    result_series, md_rows = _series_results(out, sp, series, methods, repeats)
    result = {"benchmark": "stability", "preset": preset, "methods": methods, "repeats": repeats,
              "series": result_series, "breakdown_rule": _breakdown_rule(repeats),
              "train": {"preset": sp.train[0], **sp.train[1]}, "machine": machine_info(),
              "ray": {"address": (ray or RayOptions()).where, "cpus_per_task": cpus_per_task or 1}}
    result["charts"] = _charts(result_series, out, preset)
    if views is not None:
        result["fit_series"] = {"views": views}
        result["charts"].append(views["chart"])
    path = write_results(out, "stability", result, _markdown(result, md_rows, views))
    print(f"wrote {path}")
    return result


def _views_series(out: Path, sp: StabilityPreset, model, preset: str) -> dict | None:
    """The fit-only views series and its chart (None when the preset has none)."""
    from morf.bench.stability_views import run_views, views_chart

    if sp.views is None:
        return None
    views = run_views(out, sp.views, model)
    views["chart"] = str(views_chart(views, out / "stability_views.png",
                                     f"A turn in a few views: fit against the truth ({preset})"))
    return views
