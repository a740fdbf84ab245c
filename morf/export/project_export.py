"""Export a capture project's trained avatar: the function behind ``morf export`` and the studio.

Picks the training run (the newest finished one that is not an RGB floor, or a named one), builds the int8 calibration
and held-out views from the project's body fits, loads the trained avatar and calls
:func:`morf.export.export_avatar.export_avatar`, which builds the folder beside its target and
moves it into place (``PROJECT/avatar`` by default), so a failed or stopped export leaves the
previous avatar intact.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.errors import ProjectError
from morf.io.lock import project_lock
from morf.pipeline.control import Progress, StageControl
from morf.raster.neural_raster import LAYOUTS
from morf.train.run_files import AVATAR_FILE, CONFIG_FILE, finished_run_dirs, run_path



@dataclass(frozen=True)
class ProjectExportConfig:
    """What ``export_project`` exports and how."""

    run: str | None = None  # run name under PROJECT/runs (None: the newest finished run)
    out: str | None = None  # output folder (None: PROJECT/avatar)
    input_layout: str = "nhwc"  # renderer input layout (morf.raster.neural_raster.LAYOUTS)
    calibration_views: int = 32  # training views used to calibrate int8 (spread over the capture)
    heldout_every: int = 8  # every this-many-th training view is held out of calibration for the report
    fits: str = "auto"  # body fits to pose the views: auto | fits | ground-truth (as 'morf train --fits')
    force: bool = False  # write into an existing non-empty ``out``, replacing only the export's own files

    def validate(self) -> None:
        if self.input_layout not in LAYOUTS:
            raise ProjectError(f"unknown renderer input layout {self.input_layout!r}; choose one of {', '.join(LAYOUTS)}")
        if self.calibration_views < 1:
            raise ProjectError(f"calibration views must be >= 1, got {self.calibration_views}")
        if self.heldout_every < 2:
            raise ProjectError(f"heldout_every must be >= 2 (1 would hold out every view), got {self.heldout_every}")


# Below this the player's largest scale is about the training views' own, and calibrating int8 on
# views that much closer adds nothing but time.
PLAYBACK_ZOOM_MIN = 1.15


def is_floor_run(run_dir: Path) -> bool:
    """Whether a run is the RGB floor (``morf train --method rgb``), which has no network to export."""
    try:
        return json.loads((Path(run_dir) / CONFIG_FILE).read_text()).get("method") == "rgb"
    except (OSError, ValueError, AttributeError):
        return False


def floor_error(run_dir: Path) -> ProjectError:
    return ProjectError(f"run {run_dir.name!r} is the RGB floor (method rgb: the frames projected into a colour "
                        "texture, for 'morf eval'); it has no renderer to export; pick a trained run with --run")


def pick_run(project, name: str | None) -> Path:
    """``PROJECT/runs/<name>``, or the newest finished run; one-line errors otherwise."""
    runs = Path(project.runs_dir)
    if name:
        d = run_path(project, name)
        if not d.is_dir():
            raise ProjectError(f"no run named {name!r} in {runs}")
        if not (d / AVATAR_FILE).is_file():
            raise ProjectError(f"run {name!r} has not finished (no avatar.pt); resume it with 'morf train'")
        if is_floor_run(d):
            raise floor_error(d)
        return d
    done = [d for d in finished_run_dirs(project) if not is_floor_run(d)]
    if not done:
        raise ProjectError(f"no finished training run in {runs}; run 'morf train {project.root}' first")
    return done[-1]


def exported_run(project) -> str | None:
    """The run ``PROJECT/avatar`` was exported from, when that export is current (written after the
    run's avatar.pt); None without an avatar folder, or when the run was trained again since."""
    from morf.export.avatar_folder import MANIFEST

    path = Path(project.avatar_dir) / MANIFEST
    try:
        run = json.loads(path.read_text())["source"]["run"]
        trained = (Path(project.runs_dir) / run / AVATAR_FILE).stat().st_mtime
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return run if path.stat().st_mtime >= trained else None


def project_views(project, camera, num_bones: int, fits_source: str = "auto", heldout_every: int = 8):
    """(calibration, held-out) :class:`~morf.export.export_avatar.View` lists from the body fits.

    Views are the project's training frames (the user's and the filter's decisions applied) that
    the fit covers; every ``heldout_every``-th of them is held out of int8 calibration.
    """
    from morf.export.export_avatar import View
    from morf.train.data import load_body_fits

    fits = load_body_fits(project, fits_source)
    rot, tr = fits.rotvecs, fits.transl
    if rot.ndim != 3 or rot.shape[1:] != (num_bones, 3):
        raise ProjectError(f"body fits have rotvecs of shape {rot.shape}, expected (N, {num_bones}, 3); re-run 'morf fit'")
    usable = [i for i in range(len(rot)) if fits.valid[i]]
    covered = set(usable)
    frames = [i for i in project.training_frames() if i in covered] or usable
    if not frames:
        raise ProjectError(f"the body fits of {project.root} cover no frame; re-run 'morf fit'")
    views = [View(np.asarray(rot[i], np.float32), np.asarray(tr[i], np.float32), camera) for i in frames]
    k = heldout_every
    held = views[k - 1::k]
    calib = [v for j, v in enumerate(views) if j % k != k - 1] or views
    return calib, held


def avatar_offsets(project, trained, run_dir: Path) -> np.ndarray | None:
    """(V,) clothing offsets of the body ``trained`` (the TrainedAvatar of ``run_dir``) learned on:
    those of the fits the run trained on (its log names them; the ground truth has none) for a
    dressed run (:func:`morf.train.data.clothing_offsets`), None for a naked one. Every writer of
    the avatar's mesh (the folder's mesh.npz, glTF) dresses the body with these."""
    from morf.train.data import clothing_offsets, load_body_fits
    from morf.train.run_files import RunFiles

    return clothing_offsets(load_body_fits(project, RunFiles(run_dir).fits_source()), trained.dressed)


def trained_scale(camera, views, config) -> dict:
    """The largest scale the renderer was trained at: pixels per metre at the body's root over the
    training views, times the zoom of the ``zoom_resolution`` crops. The player draws closer
    views through this scale (:mod:`morf.raster.view_scale`)."""
    from morf.raster.view_scale import pixels_per_metre

    zoom = config.zoom_resolution / config.resolution if config.zoom_resolution else 1.0
    scale = max(pixels_per_metre(camera, v.transl) for v in views) * zoom
    return {"max_pixels_per_metre": round(float(scale), 3),
            "meaning": "pixels per metre at the body's root in the largest training frames (the zoomed crops); "
                       "the player draws closer views at this scale and enlarges them"}


def export_project(project, cfg: ProjectExportConfig = ProjectExportConfig(), control: StageControl | None = None,
                   body_model=None) -> dict:
    """Export the project's trained avatar to ``cfg.out`` (default PROJECT/avatar); returns its manifest.

    Args:
        project: a CaptureProject with body fits (or synthetic ground truth) and a finished run.
        cfg: which run, where to, and the int8 calibration choices.
        control: progress reports and pause / stop points (``morf.pipeline.control``).
        body_model: a loaded body model (optional; loaded on demand).
    The output follows :mod:`morf.io.outputs`; writing PROJECT/avatar holds the project's export lock.
    """
    cfg.validate()
    claim = claim_export_folder(project, cfg)
    if claim.path.resolve() != Path(project.avatar_dir).resolve():  # outside the project: nothing there to lock
        return _export(project, cfg, claim, control, body_model)
    with project_lock(project.root, "export"):
        _remove_stale_builds(Path(project.avatar_dir))
        return _export(project, cfg, claim, control, body_model)


def _remove_stale_builds(avatar_dir: Path) -> None:
    """Folders an export killed mid-way left beside PROJECT/avatar (``.avatar.<random>.tmp``, made by
    :func:`morf.io.outputs.staged_folder`): the export's own, and with the lock held no other export
    is building one now."""
    import shutil

    for stale in avatar_dir.parent.glob(f".{avatar_dir.name}.*.tmp"):
        if stale.is_dir() and not stale.is_symlink():
            shutil.rmtree(stale, ignore_errors=True)


def claim_export_folder(project, cfg: ProjectExportConfig):
    """The output rule (:mod:`morf.io.outputs`) for ``cfg.out``: PROJECT/avatar is the export's own
    place; any other non-empty folder needs ``cfg.force``."""
    from morf.export.avatar_folder import previous_avatar_files
    from morf.io.outputs import claim_output_folder

    out = Path(cfg.out) if cfg.out else Path(project.avatar_dir)
    return claim_output_folder(out, "morf export", cfg.force, previous=previous_avatar_files(out),
                               own_place=project.avatar_dir)


def _export(project, cfg: ProjectExportConfig, claim, control: StageControl | None, body_model) -> dict:
    """:func:`export_project` once its output is claimed (and the project's export lock held)."""
    from morf.export.calibration_views import playback_zoom
    from morf.export.export_avatar import ExportConfig, export_avatar
    from morf.train.trained_avatar import load_trained_avatar

    control = control or StageControl()
    run_dir = pick_run(project, cfg.run)
    control.report(Progress("export", 0, 5, f"loading run {run_dir.name}"))
    trained = load_trained_avatar(run_dir)
    if trained.method == "rgb":
        raise floor_error(run_dir)
    if body_model is None:
        from morf.body import load_body_model

        body_model = load_body_model("anny")
    control.check()
    # The training camera (the crop the renderer learned on) when the run saved one.
    camera = trained.camera or project.camera()
    calib, held = project_views(project, camera, len(body_model.bone_names), cfg.fits, cfg.heldout_every)
    stride = max(1, len(calib) // cfg.calibration_views)  # spread calibration over the whole turn
    out = claim.path
    scale = trained_scale(camera, calib + held, trained.config)
    zoom = playback_zoom(camera, [v.transl for v in calib + held], scale["max_pixels_per_metre"])
    ecfg = ExportConfig(input_layout=cfg.input_layout, max_calibration_views=cfg.calibration_views,
                        playback_zoom=zoom if zoom > PLAYBACK_ZOOM_MIN else 0.0,
                        extra={"source": {"project": str(Path(project.root).resolve()), "run": run_dir.name,
                                          "method": trained.method}, "trained_scale": scale})
    manifest = export_avatar(out, texture=trained.texture, renderer=trained.renderer, body_model=body_model,
                             shape=trained.shape, calibration=calib[::stride], heldout=held, cfg=ecfg,
                             control=control, claim=claim, offsets=avatar_offsets(project, trained, run_dir),
                             view_colours=trained.view_colours)
    return manifest
