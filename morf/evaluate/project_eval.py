"""``evaluate_project``: score a project's finished runs on the frames they never trained on, beside
the RGB floor, and write ``eval.json``, a comparison sheet and y-t slices per target.

For each run (default: every finished run) and each target that applies to it
(:mod:`morf.evaluate.targets`), the target's frames are rasterized through the run's working
camera at the evaluation side (:mod:`morf.evaluate.frames`) and scored with
:func:`morf.train.project_run.evaluate_frames` (PSNR / SSIM over the image and the person, both
composited over the capture's backdrop colour; temporal flicker over consecutive target frames).
The floor (method rgb, :mod:`morf.train.floor`) with each evaluated hold-out setting is included,
built first when the project has none. LPIPS (:mod:`morf.avatar.lpips`, on the same composited
images, :mod:`morf.evaluate.perceptual`) is computed when its weights are on disk (``lpips`` /
``$MORF_LPIPS_WEIGHTS`` and ``vgg`` / ``$MORF_VGG16_WEIGHTS``) and reported as null otherwise.

Detail scores (:mod:`morf.evaluate.detail_eval`): the person, the head and the hands of every
frame, at the crop's native size whatever the evaluation side, with scores that tolerate a few
pixels of misalignment and do not reward blur; their head crops make a third image per target.
A capture hold-out's detail gets a reference row, the nearest seen frame copied in place of a
render (:mod:`morf.evaluate.reference`), and with ``seen`` every run is also scored on those
seen frames (target ``seen-k<K>``), so its loss on frames it saw and on frames it did not show apart.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from morf.body.parts import part_atlas
from morf.errors import ProjectError
from morf.evaluate import reference
from morf.evaluate.results import EvalResult, RunScores, TargetEntry, TargetScores
from morf.evaluate.pose_refine import RefineConfig
from morf.evaluate.runs import RunInfo, find_floor, floor_run_name, free_for_floor, read_run, select_runs
from morf.evaluate.targets import (EvalTarget, dataset_test_target, holdout_target, novel_poses_target, seen_target,
                                   trained_on)

LPIPS_NOTE = ("not computed: no LPIPS weights given (--lpips PATH or $MORF_LPIPS_WEIGHTS: the lpips package's "
              "weights/v0.1/vgg.pth, with the VGG-16 weights from --vgg PATH or $MORF_VGG16_WEIGHTS)")
LPIPS_KEYS = ("lpips", "lpips_person")  # TargetScores' LPIPS fields


def lpips_note(metric) -> str:
    """eval.json's ``lpips`` entry: what was computed from which files, or why nothing was."""
    if metric is None:
        return LPIPS_NOTE
    lin, vgg = metric.files or ("?", "?")
    return (f"LPIPS v0.1 vgg (Zhang et al. 2018) from {lin} and {vgg}, on the composited images; lpips_person "
            "averages every level over the person mask resized to it (MoRF's extension)")


@dataclass(frozen=True)
class EvalConfig:
    """What ``morf eval`` scores and where it writes.

    Fields:
        runs: run names (empty: every finished run); out: output folder (None: PROJECT/eval);
        floor: include the RGB floor of each hold-out setting (built when missing);
        resolution: None (each run's training side), "native" (the crop's capture pixels) or a side;
        sheet_rows: frames per comparison sheet; sheet_runs: the runs given a column on the sheets
        and y-t slices (empty: every scored run; the floors always get one);
        lpips, vgg: the LPIPS linear-layer and VGG-16 weights files (None: ``$MORF_LPIPS_WEIGHTS``,
        ``$MORF_VGG16_WEIGHTS``; no LPIPS file at all: LPIPS is null);
        refine_poses: refine every frame's pose against its image with each run's avatar frozen
        before scoring (:mod:`morf.evaluate.pose_refine`), the floor included; refine: its settings.
        detail: score the person, head and hands at native size and write the head crops, with the
        nearest seen frame's reference on capture hold-outs;
        seen: also score each run on the training frames nearest its held-out ones (``seen-k<K>``);
        force: write into an existing non-empty ``out`` (replacing only eval's own files there).
    """

    runs: tuple[str, ...] = ()
    out: str | None = None
    floor: bool = True
    resolution: int | str | None = None
    sheet_rows: int = 4
    sheet_runs: tuple[str, ...] = ()
    lpips: str | None = None
    vgg: str | None = None
    refine_poses: bool = False
    refine: RefineConfig = RefineConfig()
    detail: bool = True
    seen: bool = False
    force: bool = False

    def on_sheet(self, run: RunInfo) -> bool:
        return run.is_floor or not self.sheet_runs or run.name in self.sheet_runs


@dataclass
class _TargetResults:
    """Accumulates one target's scores and views while runs are evaluated."""

    target: EvalTarget
    column: float | None = None
    real: object = None  # SequenceViews of the real frames at the largest side seen
    real_side: int = 0
    rows: list[int] = field(default_factory=list)
    scored: list = field(default_factory=list)  # (RunInfo, TargetScores, SequenceViews, head crops)
    real_heads: dict = field(default_factory=dict)  # sheet row -> the real frame's head crop, largest seen
    reference: object = None  # morf.evaluate.reference.Reference of a capture hold-out, from its first run


def ensure_floors(project, runs: list[RunInfo], model, say: Callable[[str], None]) -> list[RunInfo]:
    """The RGB floor of every (hold-out setting, fits) pair among ``runs`` not already among them:
    the newest existing one, else one built now (at the largest training side of the runs with that
    setting, on their fits). A run trained on fitted bodies is never compared with a floor built on
    ground-truth bodies, or the other way round."""
    from morf.train.floor import floor_request, train_floor

    out = []
    for k, by, source in sorted({(r.holdout, r.holdout_by, r.fits_source) for r in runs if not r.is_floor}):
        if any(r.is_floor and (r.holdout, r.holdout_by, r.fits_source) == (k, by, source) for r in runs):
            continue
        found = find_floor(project, k, source, by)
        if found is None:
            group = [r for r in runs if (r.holdout, r.holdout_by, r.fits_source) == (k, by, source)]
            side = max(r.config.resolution for r in group)
            name = floor_run_name(project, k, source, by)
            if not free_for_floor(project.runs_dir / name):
                raise ProjectError(f"{project.runs_dir / name} exists and is not an RGB floor; rename it, or pass "
                                   "--no-floor")
            say(f"building the RGB floor with hold-out {k} at {side} px ...")
            res = train_floor(project, floor_request(side, k, by), name, source, model, restart=True)
            found = read_run(res.run_dir)
        out.append(found)
    return out


def evaluate_project(project, cfg: EvalConfig = EvalConfig(), model=None,
                     say: Callable[[str], None] = lambda line: None) -> EvalResult:
    """Evaluate, write everything into the output folder, and return what eval.json holds.

    The output folder follows :mod:`morf.io.outputs` (``PROJECT/eval`` is eval's own place; another
    non-empty folder needs ``cfg.force``, and then only eval's own files are replaced); the
    project's ``eval`` lock is held while it writes.
    """
    from morf.io.lock import project_lock
    from morf.io.outputs import claim_output_folder

    own = Path(project.root) / "eval"
    out = Path(cfg.out) if cfg.out else own
    claim = claim_output_folder(out, "morf eval", cfg.force, previous=_earlier_files(out), own_place=own)
    with project_lock(project.root, "eval"):
        return _evaluate(project, cfg, model, say, claim)


def _earlier_files(out: Path) -> frozenset[str]:
    """The files an earlier ``morf eval`` wrote into ``out``: its record, else what its eval.json names."""
    import json

    from morf.io.outputs import read_record

    names = read_record(out, "morf eval")
    if names:
        return names
    try:
        targets = json.loads((out / "eval.json").read_text())["targets"]
        return frozenset({"eval.json"} | {t[k] for t in targets.values() for k in ("sheet", "slices", "heads")
                                          if isinstance(t.get(k), str) and "/" not in t[k]})
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return frozenset()


def _evaluate(project, cfg: EvalConfig, model, say, claim) -> EvalResult:
    """:func:`evaluate_project` once the output is claimed and the lock held."""
    from morf.avatar.lpips import find_lpips
    from morf.io.outputs import write_record
    from morf.train.data import load_body_fits
    from morf.train.trained_avatar import load_trained_avatar

    load_body_fits(project, "auto")  # a project without fits fails here, in one line
    metric = find_lpips(cfg.lpips, cfg.vgg)  # None without weights; bad files fail here, before any work
    runs = select_runs(project, cfg.runs)
    if model is None:
        from morf.body import load_body_model

        model = load_body_model("anny")
    if cfg.floor:
        runs = [r for r in runs if not r.is_floor] + [r for r in runs if r.is_floor] + ensure_floors(
            project, runs, model, say)
    fits_cache: dict = {}

    def fits_of(source):
        if source not in fits_cache:
            fits_cache[source] = load_body_fits(project, source)
        return fits_cache[source]

    novel = novel_poses_target(project)
    targets: dict[str, _TargetResults] = {}
    report_runs, skipped = {}, {}
    for run in runs:
        avatar = load_trained_avatar(run.root)
        if avatar.camera is None:
            skipped[run.name] = "its avatar.pt stores no working camera (trained by an older MoRF)"
            continue
        fits = fits_of(run.fits_source)
        seen = seen_target(project, fits, run.holdout, run.holdout_by) if cfg.seen and not run.is_floor else None
        held = holdout_target(project, fits, run.holdout, run.holdout_by)
        mine = [t for t in (held, seen, dataset_test_target(project, fits), novel) if t]
        if not mine:
            skipped[run.name] = ("trained on every usable frame and the project has no hold-out sequence or test "
                                 "labels; retrain with --holdout K")
            continue
        scores = {}
        for target in mine:
            tr = _target_slot(targets, target)
            scores[tr.target.key] = _score(project, model, avatar, run, target, fits, tr, cfg, metric, say)
        report_runs[run.name] = RunScores(run.config.method, run.holdout, run.config.resolution, run.fits_source,
                                          run.is_floor, scores)
    if not targets:
        raise ProjectError("nothing to evaluate: " + "; ".join(f"{k}: {v}" for k, v in skipped.items()))
    out = claim.path
    order = sorted(targets, key=lambda k: (k == "novel-poses", k))  # capture frames first
    result = EvalResult(str(Path(project.root).resolve()), cfg.resolution or "training", lpips_note(metric),
                        report_runs, skipped, {k: _write_target(targets[k], out) for k in order},
                        "refined" if cfg.refine_poses else "given")
    from morf.io import atomic_write_json

    atomic_write_json(out / "eval.json", result.to_dict())
    written = {"eval.json"} | {n for e in result.targets.values() for n in (e.sheet, e.slices, e.heads) if n}
    for name in claim.previous - written:  # an earlier eval's images of targets gone since
        (out / name).unlink(missing_ok=True)
    write_record(out, "morf eval", written)
    return result


def _target_slot(targets: dict, target: EvalTarget) -> _TargetResults:
    """The results slot of a target; runs on other fits, with other held-out frames, get their own."""
    for tr in targets.values():
        if re.sub(r"-\d+$", "", tr.target.key) == target.key and tr.target.frame_ids == target.frame_ids:
            return tr
    key = target.key if target.key not in targets else f"{target.key}-{len(targets)}"
    targets[key] = _TargetResults(replace(target, key=key))
    return targets[key]


def _score(project, model, avatar, run: RunInfo, target: EvalTarget, fits, tr: _TargetResults, cfg: EvalConfig,
           metric, say) -> TargetScores:
    from morf.evaluate.frames import eval_side, scaled_camera, target_frames
    from morf.evaluate.silhouette import mask_iou
    from morf.evaluate.views import person_column, real_views, render_views, sheet_rows
    from morf.train.data import clothing_offsets
    from morf.train.project_run import evaluate_frames

    side = eval_side(avatar.camera, project.camera(), cfg.resolution, avatar.renderer.cfg.multiple)
    camera = scaled_camera(avatar.camera, side)
    offsets = clothing_offsets(fits, avatar.dressed)  # the body the run trained on, as the player draws it
    frames = target_frames(project, model, target, fits, avatar.shape.numpy(), camera, offsets)
    say(f"{run.name}: {tr.target.key}, {frames.num_frames} frames at {side} px")
    refined, poses = None, None
    if cfg.refine_poses:
        frames, refined, poses = _refine(project, model, avatar, target, fits, frames, camera, cfg.refine, say,
                                          offsets)
    # a photo set's views are no sequence: flicker between unrelated photos means nothing
    scores = evaluate_frames(avatar, frames, ordered=not (target.key.startswith("holdout") and project.unordered_views))
    colour = torch.tensor(scores.background, dtype=torch.float32)
    if tr.column is None:
        tr.column, tr.rows = person_column(frames), sheet_rows(frames.num_frames, cfg.sheet_rows)
    views = None
    if cfg.on_sheet(run):
        if side > tr.real_side:
            tr.real, tr.real_side = real_views(frames, colour, tr.rows, tr.column), side
        views = render_views(avatar, frames, colour, tr.rows, tr.column)
    detail = None
    if cfg.detail:
        detail, native, native_camera = _detail(project, model, avatar, target, fits, frames, camera, colour, poses,
                                                tr.rows, offsets)
        if tr.reference is None and not run.is_floor and reference.applies(project, target):
            tr.reference = reference.nearest_frame_reference(project, model, fits, target, native, native_camera,
                                                             colour, part_atlas(model), detail.max_shift, tr.rows,
                                                             offsets)
        for row, (real, _) in detail.crops.items():
            if real.shape[0] > tr.real_heads.get(row, np.zeros((0,))).shape[0]:
                tr.real_heads[row] = real
    lpips = None
    if metric is not None:
        from morf.evaluate.perceptual import lpips_scores

        lpips = lpips_scores(metric, avatar, frames, colour)
    # how many of these frames the run trained on (0 for its own hold-out); None for the novel poses
    seen = (trained_on(project, fits, run.holdout, target.frame_ids, run.holdout_by) if target.kind == "capture"
            else None)
    result = TargetScores.of(scores, lpips, side, seen, refined, None if detail is None else detail.to_dict(),
                             mask_iou(avatar, frames))
    if views is not None:
        tr.scored.append((run, result, views, {} if detail is None else {r: c[1] for r, c in detail.crops.items()}))
    return result


def _detail(project, model, avatar, target, fits, frames, camera, colour, poses, rows, offsets=None):
    """(DetailResult, the FrameSet scored, its camera): the detail scores of ``avatar`` on ``target``
    at the crop's native size, on ``frames`` when they are at that size, else on the target
    rasterized again there (the body dressed by ``offsets``; in the refined poses when ``poses`` =
    (RefinedPoses, shape) is given)."""
    from morf.evaluate.detail import max_shift_for
    from morf.evaluate.detail_eval import detail_scores
    from morf.evaluate.frames import eval_side, scaled_camera, target_frames
    from morf.train.data import crop_of

    native = eval_side(avatar.camera, project.camera(), "native", avatar.renderer.cfg.multiple)
    if native != frames.resolution:
        camera = scaled_camera(avatar.camera, native)
        frames = target_frames(project, model, target, fits, avatar.shape.numpy(), camera, offsets)
        if poses is not None:
            from morf.evaluate.pose_refine import reposed_frames

            frames = reposed_frames(frames, model, poses[0], poses[1], camera)
    shift = max_shift_for(native, crop_of(project.camera(), avatar.camera)[2])
    return detail_scores(avatar, frames, colour, part_atlas(model), shift, rows, target.frame_ids), frames, camera


def _refine(project, model, avatar, target, fits, frames, camera, rcfg: RefineConfig, say, offsets=None):
    """``frames`` re-rasterized in poses refined against their images with ``avatar`` frozen (the
    body dressed by ``offsets``, as the run trained and the player draws it); the
    mean L1 of the composited render (before, after); and (RefinedPoses, shape)."""
    import time

    from morf.evaluate.frames import target_poses
    from morf.evaluate.pose_refine import refine_poses, reposed_frames
    from morf.train.project_run import backdrop_colour

    rot, tr, shape = target_poses(project, target, fits, avatar.shape.numpy())
    t0 = time.perf_counter()
    res = refine_poses(avatar, model, frames, rot, tr, shape, camera, backdrop_colour(frames), rcfg, offsets=offsets)
    say(f"  poses refined in {time.perf_counter() - t0:.0f} s: L1 {res.loss_before:.4f} -> {res.loss_after:.4f}")
    return (reposed_frames(frames, model, res, shape, camera), (round(res.loss_before, 5), round(res.loss_after, 5)),
            (res, shape))


def _write_target(tr: _TargetResults, out: Path) -> TargetEntry:
    """Write the target's sheet, y-t image and head crops; its eval.json entry."""
    from morf.evaluate.sheet import Column, comparison_sheet, head_sheet, yt_slices
    from morf.io import write_image

    t = tr.target

    def label(run, m: TargetScores):
        p = m.psnr_person
        return (run.name, "person PSNR " + (f"{p:.2f} dB" if p is not None else "n/a"))

    ordered = [s for s in tr.scored if not s[0].is_floor] + [s for s in tr.scored if s[0].is_floor]
    columns = [Column(("real", f"{len(t.frame_ids)} frames"), tr.real.rows, tr.real.slice)]
    columns += [Column(label(run, m), v.rows, v.slice) for run, m, v, _ in ordered]
    ids = [t.frame_ids[r] for r in tr.rows]
    sheet = comparison_sheet(columns, [f"frame {i}" for i in ids])
    slices = yt_slices(columns, (f"y-t slices: image column x = {tr.column:.0%} of the crop (the person's centre)",
                                 f"time runs left to right over {len(t.frame_ids)} frames"))
    write_image(out / f"sheet-{t.key}.png", sheet)
    write_image(out / f"yt-{t.key}.png", slices)
    names = ("real",) + tuple(run.name for run, _, _, _ in ordered)
    heads, heads_size = None, None
    if tr.real_heads:
        def head_label(run, m: TargetScores):
            v = m.metric("head_ssim_shift")
            return (run.name, "head SSIM+-shift " + (f"{v:.3f}" if v is not None else "n/a"))

        crops = [(("real", "native size"), tr.real_heads)] + [(head_label(run, m), c) for run, m, _, c in ordered]
        if tr.reference is not None:
            v = tr.reference.detail.scores.get("head_ssim_shift")
            crops.append(((reference.REFERENCE_NAME, "head SSIM+-shift " + (f"{v:.3f}" if v is not None else "n/a")),
                          {r: c[1] for r, c in tr.reference.detail.crops.items()}))
        image = head_sheet(crops, [r for r in tr.rows if r in tr.real_heads],
                           [f"frame {t.frame_ids[r]}" for r in tr.rows if r in tr.real_heads])
        heads, heads_size = f"heads-{t.key}.png", (image.shape[1], image.shape[0])
        write_image(out / heads, image)
    return TargetEntry(t.title, t.holdout, tuple(t.frame_ids), tuple(ids), names, round(tr.column, 4),
                       f"sheet-{t.key}.png", (sheet.shape[1], sheet.shape[0]), f"yt-{t.key}.png",
                       (slices.shape[1], slices.shape[0]), heads, heads_size,
                       None if tr.reference is None else tr.reference.to_dict())


def format_table(result: EvalResult) -> str:
    """A short plain-text table of the scores, one block per target."""
    lines = []
    lpips = any(m.metric(k) is not None for e in result.runs.values() for m in e.targets.values()
                for k in LPIPS_KEYS)  # LPIPS columns only when computed
    for key, t in result.targets.items():
        lines.append(f"{key}: {t.title}, {len(t.frame_ids)} frames"
                     + (", poses refined against the frames (--refine-poses)" if result.poses == "refined" else ""))
        lines.append(f"  {'run':<24} {'px':>5} {'PSNR':>7} {'person':>7} {'SSIM':>6} {'person':>6} {'flicker':>8}"
                     + f" {'warp':>7} {'maskIoU':>7}" + (f" {'LPIPS':>6} {'person':>6}" if lpips else ""))
        for name in result.scored_runs(key):
            m = result.runs[name].targets[key]

            def f(k, fmt):
                return format(m.metric(k), fmt) if m.metric(k) is not None else "n/a"

            lines.append(f"  {name:<24} {m.resolution:>5} {f('psnr', '7.2f'):>7} {f('psnr_person', '7.2f'):>7} "
                         f"{f('ssim', '6.3f'):>6} {f('ssim_person', '6.3f'):>6} {f('temporal', '8.4f'):>8}"
                         f" {f('warp_flicker', '7.4f'):>7} {f('mask_iou', '7.3f'):>7}"
                         + (f" {f('lpips', '6.3f'):>6} {f('lpips_person', '6.3f'):>6}" if lpips else ""))
        real = next((result.runs[n].targets[key].warp_flicker_real for n in result.scored_runs(key)
                     if result.runs[n].targets[key].warp_flicker_real is not None), None)
        if real is not None:  # the same real frames for every run
            lines.append(f"  (warp: flicker that forgives a steady misregistration; the real frames' own, for scale: {real:.4f})")
        lines += _detail_lines(result, key)
    for name, why in result.skipped.items():
        lines.append(f"skipped {name}: {why}")
    return "\n".join(lines)


def _detail_lines(result: EvalResult, key: str) -> list[str]:
    """The detail block of one target: per run and region, SSIM at the best shift, GMSD (lower is
    better) and the high-frequency ratio render / real (under 1: blurrier than the real frames) over
    the region and inside the real person, away from its mask's edge."""
    from morf.evaluate.detail import HF_INSET

    names = [n for n in result.scored_runs(key) if result.runs[n].targets[key].detail]
    if not names:
        return []
    first = result.runs[names[0]].targets[key].detail
    lines = [f"  detail at native size ({first.get('resolution')} px, shift +-{first.get('max_shift')} px): "
             "SSIM at the best shift / GMSD (lower is better) / high-frequency ratio render:real over the region / "
             f"the same inside the person ({HF_INSET} px from the real mask's edge and the render's)"]
    lines.append(f"  {'run':<24} " + " ".join(f"{g:>28}" for g in ("person", "head", "hands")))
    rows = [(name, result.runs[name].targets[key].detail) for name in names]
    ref = result.targets[key].reference
    if ref is not None:
        rows.append((f"({ref['name']})", ref["detail"]))
    for name, d in rows:
        lines.append(f"  {name:<24} " + " ".join(_detail_cell(d, g) for g in ("person", "head", "hands")))
    if ref is not None:
        lines.append(f"  ({ref['name']}: each held-out frame scored against the nearest frame the runs trained on, "
                     "copied: the capture's own change from frame to frame)")
    lines += [line for name, d in rows for line in _head_frame_lines(name, d)]
    return lines


def _detail_cell(d: dict, group: str) -> str:
    """A group's four detail scores, 28 characters wide."""
    if not d.get(f"{group}_count"):
        return f"{'n/a':>28}"
    v = [d.get(f"{group}_{s}") for s in ("ssim_shift", "gmsd", "hf_ratio", "hf_ratio_inside")]
    return " ".join("  n/a" if x is None else f"{x:5.3f}" for x in v).rjust(28)


WORST_HEADS = 5  # the lowest-scored heads each run names


def _head_frame_lines(name: str, detail: dict) -> list[str]:
    """The frames where a run's head scores lowest, and how many heads sit at the shift bound:
    further off than the score forgives (the fit's error there, not the avatar's detail)."""
    heads = detail.get("head_frames") or []
    if not heads:
        return []
    worst = sorted(heads, key=lambda h: h["ssim_shift"])[:WORST_HEADS]
    cells = ", ".join(f"{h['frame']} {h['ssim_shift']:.3f}" + (" (at the bound)" if h["at_bound"] else "")
                      for h in worst)
    bound = sum(h["at_bound"] for h in heads)
    return [f"  {name}: lowest heads (frame SSIM): {cells}; at the +-{detail.get('max_shift')} px bound in "
            f"{bound} of {len(heads)} frames"]
