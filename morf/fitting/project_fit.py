"""``fit_project``: fit a capture project and write PROJECT/fits/ (resumable, atomic).

Outputs:
    fits/fits.npz          BodyFits (rotvecs, transl, shape, residuals, IoU, fitted keypoints, config)
    fits/filter.json       {"rejected": {"12": "keypoint residual 38 px (median 6)"}, "frames": N, ...}
    fits/fit_config.json   the resolved FitConfig
    fits/checkpoint.npz    parameters after the last completed stage (resume point)
    fits/overlays/000000.jpg  one overlay per frame
    fits/done.json         written last, once every file above exists: the fit is complete

The fit counts as done only when done.json names this configuration AND every output it lists is
on disk (:func:`fit_progress`, :func:`missing_outputs`): a fit killed anywhere, even between the
last overlay and done.json, is finished by the next ``morf fit`` or ``morf run`` rather than taken
for complete. A fit that will rewrite the outputs removes done.json first. The fit resumes from
the checkpoint of its last completed stage; a checkpoint holding all stages leaves only the
evaluation, the filter and the overlays to do again (seconds).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass

import numpy as np
import torch

from morf.camera import PinholeCamera
from morf.errors import InputError, MorfError, ProjectError
from morf.fitting.config import FitConfig
from morf.fitting.evaluate import posed_chunks, silhouettes
from morf.fitting.fit import FitState, cpu_threads, default_device, finalize, fit_sequence, with_labels
from morf.fitting.frame_spacing import FrameSpacing
from morf.fitting.fits_io import CHECKPOINT_FILE, BodyFits, read_checkpoint, read_fits, save_checkpoint, save_fits
from morf.fitting.inputs import load_fit_inputs
from morf.fitting.offsets import dressed_vertices
from morf.fitting.overlays import draw_overlay
from morf.io import atomic_write_json, write_image
from morf.io.lock import project_lock
from morf.pipeline.control import Progress, StageControl
from morf.progress import progress


@dataclass(frozen=True)
class FitReport:
    """What ``fit_project`` did.

    Fields:
        fits: the saved fits; rejected: frame -> reason; seconds: wall time of this call;
        resumed_from: completed stages found in the checkpoint (0 = fresh start);
        up_to_date: nothing was recomputed (fits already complete for this config).
        spacing: one line on how far apart the fit took the frames to be ("" when up to date).
    """

    fits: BodyFits
    rejected: dict[int, str]
    seconds: float
    resumed_from: int
    up_to_date: bool = False
    spacing: str = ""


DONE_FILE = "done.json"  # PROJECT/fits/done.json: the fit's completion record, written last


@dataclass(frozen=True)
class FitProgress:
    """How far the fit of a project has come, read from PROJECT/fits/ without fitting anything.

    Fields:
        complete: done.json records a finished fit and every output it lists exists (fits.npz,
            filter.json, an overlay per frame when the fit makes them); ``fit_project`` then reports
            up to date, unless asked for another configuration.
        stages_done: fit stages the checkpoint holds (0: none).
        stages_total: stages of the fit that wrote fit_config.json (None: no fit started).
        config: that fit's configuration (None when there is none, or it is unreadable).
    """

    complete: bool
    stages_done: int = 0
    stages_total: int | None = None
    config: FitConfig | None = None

    @property
    def started(self) -> bool:
        """A fit stopped part-way: resuming it with the same configuration skips the stages done."""
        return not self.complete and self.stages_done > 0


def fit_progress(project) -> FitProgress:
    """Where the fit of ``project`` (a CaptureProject) stands."""
    out = project.fits_dir
    config = None
    try:
        config = FitConfig.from_dict(json.loads((out / "fit_config.json").read_text()))
    except (OSError, ValueError, TypeError, MorfError):
        pass
    ckpt = read_checkpoint(out / CHECKPOINT_FILE)
    done = ckpt["stage"] if ckpt is not None else 0
    record = read_done(project)
    complete = record is not None and not missing_outputs(project, bool(record["config"].get("overlays")))
    return FitProgress(complete, done, None if config is None else len(config.stages), config)


def read_done(project) -> dict | None:
    """fits/done.json ({"config": the FitConfig dict, "key": what decided the parameters, "frames":
    N}) when it records a fit of this project's frames; None when absent, unreadable or stale."""
    try:
        record = json.loads((project.fits_dir / DONE_FILE).read_text())
    except (OSError, ValueError):
        return None
    if (not isinstance(record, dict) or not isinstance(record.get("config"), dict)
            or record.get("frames") != project.num_frames):
        return None
    return record


def missing_outputs(project, overlays: bool) -> list[str]:
    """The outputs of a complete fit that are not on disk (paths inside fits/): fits.npz,
    filter.json and, when the fit makes them, one overlay per frame."""
    out = project.fits_dir
    missing = [name for name in ("fits.npz", "filter.json") if not (out / name).is_file()]
    if overlays:
        have = {p.name for p in (out / "overlays").glob("*.jpg")} if (out / "overlays").is_dir() else set()
        missing += [f"overlays/{i:06d}.jpg" for i in range(project.num_frames) if f"{i:06d}.jpg" not in have]
    return missing


def _resume_key(cfg: FitConfig, camera: PinholeCamera) -> dict:
    """The parts of a fit that decide its parameters (outputs-only options excluded)."""
    d = cfg.to_dict()
    for k in ("overlays", "iou_resolution", "filter", "chunk_frames"):
        d.pop(k, None)
    d["camera"] = camera.to_dict()
    return json.loads(json.dumps(d, sort_keys=True))  # the form it takes after a round trip to disk


def project_camera(project, focal: float | None) -> PinholeCamera:
    cam = project.camera()
    if focal is not None:
        if focal <= 0:
            raise InputError(f"--focal must be positive, got {focal}")
        cam = PinholeCamera(float(focal), float(focal), cam.cx, cam.cy, cam.width, cam.height, cam.R, cam.t)
    return cam


def fit_project(project, cfg: FitConfig, *, model=None, focal: float | None = None, restart: bool = False,
                control: StageControl | None = None, device: torch.device | None = None) -> FitReport:
    """Fit every frame of ``project`` (a CaptureProject) and write PROJECT/fits/, holding the
    project's fit lock (a second writer is refused)."""
    with project_lock(project.root, "fit"):
        return _fit_project(project, cfg, model, focal, restart, control or StageControl(), device)


def _fit_project(project, cfg: FitConfig, model, focal: float | None, restart: bool, control: StageControl,
                 device: torch.device | None) -> FitReport:
    t0 = time.perf_counter()
    if model is None:
        from morf.body import load_body_model

        model = load_body_model("anny")
    device = device or default_device()
    camera = project_camera(project, focal)
    inputs = load_fit_inputs(project, camera, cfg.silhouette_resolution, cfg.iou_resolution,
                             need_masks=True)
    out = project.fits_dir
    out.mkdir(parents=True, exist_ok=True)
    key = _resume_key(cfg, camera)
    ckpt = None if restart else read_checkpoint(out / CHECKPOINT_FILE)
    start = None
    if ckpt is not None and ckpt["config"] == key and ckpt["rotvecs"].shape[0] == inputs.num_frames:
        spacing = None
        if ckpt["gaps"] is not None and len(ckpt["gaps"]) == max(0, inputs.num_frames - 1):
            spacing = FrameSpacing(np.asarray(ckpt["gaps"], np.float64), ckpt["spacing"])
        start = FitState(torch.as_tensor(ckpt["rotvecs"]), torch.as_tensor(ckpt["transl"]),
                         torch.as_tensor(ckpt["shape"]), ckpt["stage"], torch.as_tensor(ckpt["offsets"]), spacing,
                         _swapped(ckpt["swapped"], inputs.num_frames))
    resumed = start.stage if start is not None else 0
    record = None if restart else read_done(project)
    settings = json.loads(json.dumps(cfg.to_dict()))  # as done.json holds it (tuples become lists)
    if (record is not None and record.get("key") == key and record["config"] == settings
            and not missing_outputs(project, cfg.overlays)):
        return FitReport(read_fits(project.fits_path), project.auto_filter(), time.perf_counter() - t0, resumed, True)
    # from here on the outputs are rewritten: the fit is not complete until done.json is back
    (out / DONE_FILE).unlink(missing_ok=True)
    atomic_write_json(out / "fit_config.json", cfg.to_dict())

    def save(state: FitState) -> None:
        save_checkpoint(out / CHECKPOINT_FILE, stage=state.stage, rotvecs=state.rotvecs.numpy(),
                        transl=state.transl.numpy(), shape=state.shape.numpy(), config=key,
                        offsets=state.offsets.numpy(),
                        gaps=None if state.spacing is None else state.spacing.gaps,
                        spacing="" if state.spacing is None else state.spacing.source, swapped=state.swapped)

    complete = start is not None and start.stage >= len(cfg.stages)
    state = start if complete else fit_sequence(model, inputs, cfg, control=control, start=start, device=device,
                                                on_stage=save)
    control.report(Progress(stage="fit", message="evaluating fits and filtering frames"))
    fits, rejected = finalize(model, inputs, cfg, state)
    save_fits(project.fits_path, fits)
    atomic_write_json(out / "filter.json", {
        "rejected": {str(k): v for k, v in rejected.items()},
        "frames": inputs.num_frames,
        "enabled": cfg.frame_filter,
        "median_keypoint_residual_px": float(np.nanmedian(fits.keypoint_residual_px)),
        "median_silhouette_iou": None if inputs.masks_eval is None else float(np.nanmedian(fits.silhouette_iou)),
    })
    if cfg.overlays:
        with cpu_threads(cfg.cpu_threads):
            write_overlays(project, model, fits, with_labels(inputs, state.swapped).keypoints, camera, rejected,
                           control)
    missing = missing_outputs(project, cfg.overlays)
    if missing:  # someone removed a file while the fit ran: never record such a fit as done
        raise ProjectError(f"{out}: {missing[0]} vanished while the fit was writing it; run 'morf fit' again")
    atomic_write_json(out / DONE_FILE, {"config": settings, "key": key, "frames": inputs.num_frames,
                                        "finished": time.strftime("%Y-%m-%d %H:%M:%S")})
    return FitReport(fits, rejected, time.perf_counter() - t0, resumed,
                     spacing="" if state.spacing is None else state.spacing.describe())


def _swapped(saved, num_frames: int) -> np.ndarray | None:
    """The checkpoint's exchanged-label frames, when it holds a list of the right length."""
    if saved is None or np.shape(saved) != (num_frames,):
        return None
    return np.asarray(saved, bool)


def write_overlays(project, model, fits: BodyFits, keypoints: np.ndarray, camera: PinholeCamera,
                   rejected: dict[int, str], control: StageControl | None = None) -> None:
    """fits/overlays/000000.jpg for every frame."""
    folder = project.fits_dir / "overlays"
    folder.mkdir(parents=True, exist_ok=True)
    device = next(iter(model.buffers())).device
    W, H = camera.width, camera.height
    rv, tr, sh = (torch.as_tensor(x, device=device) for x in (fits.rotvecs, fits.transl, fits.shape))
    off = None if fits.offsets is None else torch.as_tensor(fits.offsets, device=device)
    bar = progress(total=fits.num_frames, desc="fit overlays", unit="frame")
    for sl, out in posed_chunks(model, rv, tr, sh, chunk=8):
        verts = dressed_vertices(model, out, sh if sh.shape[0] == 1 else sh[sl], off)
        sil = silhouettes(verts, model.faces, camera, 1.0, W, H)
        for j, i in enumerate(range(sl.start, sl.stop)):
            img = draw_overlay(project.load_frame(i), sil[j], keypoints[i], fits.projected_keypoints[i],
                               rejected.get(i))
            write_image(folder / f"{i:06d}.jpg", img, jpeg_quality=85)
            bar.update(1)
        if control is not None:
            control.check()
    bar.close()
