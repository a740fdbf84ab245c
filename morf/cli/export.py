"""``morf export PROJECT [--run NAME] [--out DIR]``: the trained avatar as a portable folder
(uint8 neural texture, shaped render mesh, skeleton, fp32 + int8 ONNX renderers, manifest)."""

from __future__ import annotations

from pathlib import Path


def add_parser(sub):
    p = sub.add_parser("export", help="export a trained avatar for real-time playback (int8 ONNX + GL data)")
    p.add_argument("project", help="capture project folder")
    p.add_argument("--run", default=None, help="training run name under PROJECT/runs (default: the newest finished)")
    p.add_argument("--out", default=None, help="output folder (default: PROJECT/avatar)")
    p.add_argument("--layout", choices=("nchw", "planes"), default="nchw", help="renderer input layout")
    p.add_argument("--calibration-views", type=int, default=32, help="training views used to calibrate int8")
    return p


def _pick_run(project, name: str | None) -> Path:
    from morf.errors import ProjectError

    runs = project.runs_dir
    if name:
        d = runs / name
        if not d.is_dir():
            raise ProjectError(f"no run named {name!r} in {runs}")
        return d
    done = sorted((d for d in runs.glob("*") if (d / "avatar.pt").is_file()), key=lambda d: (d / "avatar.pt").stat().st_mtime)
    if not done:
        raise ProjectError(f"no finished training run in {runs}; run 'morf train {project.root}' first")
    return done[-1]


def project_views(project, camera, num_bones: int):
    """(calibration, held-out) views from the project's body fits: training frames, every 8th held out."""
    from morf.errors import ProjectError
    from morf.export.export_avatar import View
    from morf.io import load_npz

    fits = load_npz(project.fits_dir / "fits.npz")
    if "rotvecs" not in fits or "transl" not in fits:
        raise ProjectError(f"{project.fits_dir / 'fits.npz'} lacks rotvecs/transl; re-run 'morf fit'")
    rot, tr = fits["rotvecs"], fits["transl"]
    if rot.ndim != 3 or rot.shape[1:] != (num_bones, 3):
        raise ProjectError(f"fits rotvecs have shape {rot.shape}, expected (N, {num_bones}, 3)")
    frames = [i for i in project.training_frames() if i < len(rot)] or list(range(len(rot)))
    views = [View(rot[i], tr[i], camera) for i in frames]
    held = views[7::8]
    calib = [v for k, v in enumerate(views) if k % 8 != 7] or views
    return calib, held


def run(args) -> int:
    from morf.avatar.trained import load_trained_avatar
    from morf.body import load_body_model
    from morf.capture.project import CaptureProject
    from morf.export.export_avatar import ExportConfig, export_avatar

    project = CaptureProject.open(args.project)
    run_dir = _pick_run(project, args.run)
    trained = load_trained_avatar(run_dir)
    body = load_body_model("anny")
    camera = trained.camera or project.camera()
    calib, held = project_views(project, camera, len(body.bone_names))
    step = max(1, len(calib) // max(1, args.calibration_views))
    out = Path(args.out) if args.out else project.avatar_dir
    cfg = ExportConfig(input_layout=args.layout, max_calibration_views=args.calibration_views,
                       extra={"source": {"project": str(Path(args.project).resolve()), "run": run_dir.name,
                                         "method": trained.method}})
    manifest = export_avatar(out, texture=trained.texture, renderer=trained.renderer, body_model=body,
                             shape=trained.shape, calibration=calib[::step], heldout=held, cfg=cfg)
    q = manifest["int8_quality"]
    size = sum(f["bytes"] for f in manifest["files"].values()) / 1e6
    print(f"exported {out} ({size:.1f} MB); int8 vs fp32 on {q['views']} {q['on']} views: "
          f"PSNR {q['psnr_db']:.1f} dB, SSIM {q['ssim']:.4f}")
    return 0
