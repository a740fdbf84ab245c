"""Measure one training configuration: train (resumable), hold-out quality, playback speed.

Quality is the hold-out evaluation of ``morf bench quality`` (the synthetic novel-pose sequence
rendered with the trained torch renderer: PSNR / SSIM over the image and over the person, and
temporal flicker). Speed is the playback benchmark's measurement (``morf.bench.render``) of the
trained avatar exported at the measured size, in a separate torch-free process. Used by
``morf bench pareto`` (and its ``--auto-check``) and ``morf bench stability``.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from morf.errors import InputError, TrainingDiverged
from morf.train.frame_scores import FrameScores


@dataclass(frozen=True)
class PlaybackSpeed:
    """Playback speed of an exported avatar (:func:`measure_speed`); the fp32 one travels from its
    measuring child as JSON.

    Fields:
        fps: end to end, sequential; frame_ms: its milliseconds a frame; renderer_ms: the renderer
        graph alone, median; int8_psnr_vs_fp32_image_db: the int8 player's frames against the fp32
        player's (int8 only; None for fp32, then left out of :meth:`to_dict`).
    """

    fps: float
    frame_ms: float
    renderer_ms: float
    int8_psnr_vs_fp32_image_db: float | None = None

    def to_dict(self) -> dict:
        d = {"fps": self.fps, "frame_ms": self.frame_ms, "renderer_ms": self.renderer_ms}
        if self.int8_psnr_vs_fp32_image_db is not None:
            d["int8_psnr_vs_fp32_image_db"] = self.int8_psnr_vs_fp32_image_db
        return d

    @staticmethod
    def from_dict(d: dict) -> PlaybackSpeed:
        return PlaybackSpeed(d["fps"], d["frame_ms"], d["renderer_ms"], d.get("int8_psnr_vs_fp32_image_db"))


@dataclass(frozen=True)
class RunSpeed:
    """Playback speed of one run at one precision (:func:`speed_of_run`).

    Fields:
        playback: the measurement; int8_psnr_vs_fp32_db: the export's int8 renderer against its fp32
        one (its manifest's check, whatever precision was timed).
    """

    playback: PlaybackSpeed
    int8_psnr_vs_fp32_db: float

    def to_dict(self) -> dict:
        return {**self.playback.to_dict(), "int8_psnr_vs_fp32_db": self.int8_psnr_vs_fp32_db}

    @staticmethod
    def from_dict(d: dict) -> RunSpeed:
        return RunSpeed(PlaybackSpeed.from_dict(d), d["int8_psnr_vs_fp32_db"])


HOLDOUT_METRICS = ("psnr", "ssim", "psnr_person", "ssim_person", "temporal")


@dataclass(frozen=True)
class TrainEvaluation:
    """One training scored on the hold-out (:func:`train_and_evaluate`): what a training task sends
    back from its Ray worker, and the scores in the sweep's and the stress series' point files.

    Fields:
        params: the renderer's parameters; diverged: training raised TrainingDiverged, or a metric
            came out NaN; psnr, ssim, psnr_person, ssim_person, temporal: the hold-out metrics
            (:func:`holdout_quality`); train_minutes: the training loop's wall time, all sessions;
            steps: steps trained.
        error: the TrainingDiverged message when training raised (then there is no run: the metrics,
            minutes and steps are None, and the fields below are left out of :meth:`to_dict`);
            None when training ended.
        background, frames: the hold-out's flat backdrop colour and frame count; run: the run
            folder; eval_resolution: the scoring size in px (None in results saved before it was
            kept; then left out of :meth:`to_dict`).
    """

    params: int
    diverged: bool
    psnr: float | None = None
    ssim: float | None = None
    psnr_person: float | None = None
    ssim_person: float | None = None
    temporal: float | None = None
    train_minutes: float | None = None
    steps: int | None = None
    error: str | None = None
    background: tuple[float, ...] | None = None
    frames: int | None = None
    run: str | None = None
    eval_resolution: int | None = None

    def to_dict(self) -> dict:
        metrics = {k: getattr(self, k) for k in HOLDOUT_METRICS}
        if self.error is not None:
            return {"diverged": self.diverged, "error": self.error, "params": self.params, **metrics,
                    "train_minutes": self.train_minutes, "steps": self.steps}
        d = dict(metrics)
        if self.background is not None:
            d.update(background=list(self.background), frames=self.frames)
        d.update(diverged=self.diverged, params=self.params, train_minutes=self.train_minutes, steps=self.steps,
                 run=self.run)
        if self.eval_resolution is not None:
            d["eval_resolution"] = self.eval_resolution
        return d

    @staticmethod
    def from_dict(d: dict) -> TrainEvaluation:
        """From :meth:`to_dict`'s keys (a point file holds them among its own)."""
        background = d.get("background")
        return TrainEvaluation(d["params"], d["diverged"], *(d[k] for k in HOLDOUT_METRICS), d["train_minutes"],
                               d["steps"], d.get("error"), None if background is None else tuple(background),
                               d.get("frames"), d.get("run"), d.get("eval_resolution"))


def holdout_quality(project, run_dir, model, resolution: int | None = None) -> FrameScores:
    """PSNR / SSIM (image and person) and temporal flicker of a finished run on the project's
    synthetic hold-out sequence (the same evaluation as ``morf bench quality``), rendered and
    scored at ``resolution`` px (default: the run's training resolution; runs trained at
    different resolutions are only comparable at one common resolution). The body is the one the
    run trained on, dressed by its fits' clothing offsets when it was (as the export draws it)."""
    from morf.export.project_export import avatar_offsets
    from morf.train.data import build_holdout_frames
    from morf.train.project_run import evaluate_frames
    from morf.train.trained_avatar import load_trained_avatar

    avatar = load_trained_avatar(run_dir)
    working = avatar.camera
    if resolution is not None and resolution != working.width:
        working = working.scaled(resolution / working.width)
    holdout = build_holdout_frames(project, model, working, avatar.shape.numpy(),
                                   offsets=avatar_offsets(project, avatar, Path(run_dir)))
    if holdout is None:
        raise InputError(f"{project.root} has no hold-out sequence (a synthetic capture is needed)")
    return evaluate_frames(avatar, holdout)


def train_and_evaluate(project, cfg, run_name: str, model, fits_source: str = "ground-truth",
                       eval_resolution: int | None = None) -> TrainEvaluation:
    """Train (or resume, or reuse) ``PROJECT/runs/<run_name>`` and evaluate it (at
    ``eval_resolution`` px, default the training resolution; see :func:`holdout_quality`).

    ``diverged`` is True when training raised TrainingDiverged (then the metrics are None) or a
    metric came out NaN.
    """
    from morf.avatar.renderer import UNetRenderer, count_parameters
    from morf.train.project_run import train_project

    params = count_parameters(UNetRenderer(cfg.renderer))
    try:
        res = train_project(project, cfg, run_name, fits_source=fits_source, model=model)
    except TrainingDiverged as e:
        return TrainEvaluation(params, True, error=str(e))
    m = holdout_quality(project, res.run_dir, model, eval_resolution)
    bad = any(v is None or (isinstance(v, float) and not math.isfinite(v)) for v in (m.psnr, m.psnr_person, m.ssim))
    return TrainEvaluation(params, bool(bad), *(getattr(m, k) for k in HOLDOUT_METRICS), res.train_minutes, res.step,
                           background=m.background, frames=m.frames, run=str(res.run_dir),
                           eval_resolution=eval_resolution or cfg.resolution)


def export_for_speed(run_dir, out_dir: Path, size: int, body_model) -> dict:
    """Export the trained avatar of ``run_dir`` (texture + renderer) with views at ``size``^2."""
    from morf.export.synthetic import build_synthetic_avatar
    from morf.train.trained_avatar import load_trained_avatar

    av = load_trained_avatar(run_dir)
    return build_synthetic_avatar(out_dir, body_model=body_model, renderer_cfg=av.renderer.cfg,
                                  texture_size=av.texture.shape[-1], image_size=size, calibration_views=4,
                                  heldout_views=2, renderer=av.renderer, texture=av.texture)


def measure_speed(avatar_dir: Path, size: int, frames: int, precision: str) -> PlaybackSpeed:
    """Playback speed of an exported avatar in a torch-free child process.

    int8 uses the playback benchmark's own measurement; fp32 the same loop with the fp32 renderer.
    """
    from morf.bench.render import measure_in_child, run_torch_free
    from morf.bench.render_results import PlaybackMeasurement

    if precision == "int8":
        m = PlaybackMeasurement.from_dict(measure_in_child(Path(avatar_dir), size, frames))
        return PlaybackSpeed(m.fps_end_to_end, m.frame_ms, m.renderer_only_ms, m.int8_psnr_vs_fp32_image_db)
    return PlaybackSpeed.from_dict(run_torch_free("morf.bench.train_eval", "_fp32_child",
                                                  {"avatar": str(avatar_dir), "size": size, "frames": frames},
                                                  f"fp32 measurement of {avatar_dir}"))


def _fp32_child() -> None:
    """Child process: time the fp32 player like morf.bench.render.measure times the int8 one."""
    from morf.bench.render import bench_motion, time_player
    from morf.playback.player import Player
    from morf.raster.camera_paths import front_camera

    a = json.loads(sys.argv[1])
    size, frames = a["size"], a["frames"]
    rot, tr = bench_motion(frames + 5, 104)
    cams = [front_camera(size, yaw_deg=10.0 * i) for i in range(len(rot))]
    with Player(a["avatar"], size=size, background=(255, 255, 255), precision="fp32") as p:
        for i in list(range(5)) * 3:  # warm-up, as morf.bench.render.measure
            p.render(rot[i], tr[i], cams[i])
        seq, renderer_ms = time_player(p, rot, tr, cams, frames)
    print(json.dumps(PlaybackSpeed(1.0 / seq, seq * 1e3, renderer_ms).to_dict()))


def speed_of_run(run_dir, work: Path, size: int, frames: int, precision: str, body_model) -> RunSpeed:
    """Playback speed of one run at ``precision``, with its export's int8 check. The export is made
    once per run in ``work`` (reused by the run's other precision; the caller removes ``work`` when
    done)."""
    avatar = Path(work) / f"avatar-{Path(run_dir).name}-{size}"
    if not (avatar / "manifest.json").is_file():
        export_for_speed(run_dir, avatar, size, body_model)
    man = json.loads((avatar / "manifest.json").read_text())
    return RunSpeed(measure_speed(avatar, size, frames, precision), man["int8_quality"]["psnr_db"])
