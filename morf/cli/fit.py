"""``morf fit PROJECT``: fit the body model to every frame and filter unreliable frames."""

from __future__ import annotations

import signal

from morf.cli.options import add_config_options, read_config_option


def add_parser(sub):
    from morf.presets import PRESETS, default_preset

    p = sub.add_parser("fit", help="fit the body model to every frame (keypoints, silhouettes, temporal smoothing)")
    p.add_argument("project", help="capture project folder")
    p.add_argument("--preset", choices=tuple(PRESETS["fit"]), default=None,
                   help=f"fit preset: {' | '.join(PRESETS['fit'])} (default: {default_preset('fit')}; default, cpu "
                        "and gpu are one config; fast: fewer steps; tiny: tests; baseline: no refinements)")
    p.add_argument("--focal", type=float, default=None, help="focal length in pixels (overrides the project's camera)")
    p.add_argument("--restart", action="store_true", help="start over instead of resuming from the last completed stage")
    p.add_argument("--device", default=None, help="torch device (default: cuda when available, else cpu)")
    for name, text in (("shared-shape", "one shape for all frames"), ("silhouette", "silhouette (Dice) loss"),
                       ("temporal", "temporal smoothing"), ("frame-filter", "automatic frame filter")):
        p.add_argument(f"--no-{name}", dest=name.replace("-", "_"), action="store_false", default=None,
                       help=f"switch off the {text}")
    p.add_argument("--no-overlays", dest="overlays", action="store_false", default=None, help="skip overlay images")
    add_config_options(p, "a fit's fits/fit_config.json",
                       ("temporal_weight=100", "stages.2.iterations=30", "filter.iou_drop=0.1"))
    return p


def resolve_config(args):
    """The fit's FitConfig: the --config file or the --preset, the --no-* switches, then --set."""
    from morf.fitting.config import FitConfig
    from morf.presets import default_preset, preset

    given = read_config_option(args, "fit config")
    if given is not None:
        cfg = FitConfig.from_dict(given)
    else:
        cfg = preset("fit", args.preset or default_preset("fit"))
    changes = {k: getattr(args, k) for k in ("shared_shape", "silhouette", "temporal", "frame_filter", "overlays")
               if getattr(args, k, None) is not None}
    cfg = cfg.replace(**changes)
    if getattr(args, "set", None):
        cfg = cfg.with_settings(args.set)
    return cfg


def run(args) -> int:
    from morf.capture.project import CaptureProject
    from morf.errors import InputError

    cfg = resolve_config(args)  # the cheap checks first: torch and the fitting stack take seconds to load
    project = CaptureProject.open(args.project)

    import numpy as np
    import torch

    from morf.fitting.project_fit import fit_project
    from morf.pipeline.control import StageControl, StopRequested

    try:
        device = torch.device(args.device) if args.device else None
    except RuntimeError as e:
        raise InputError(f"bad --device: {e}") from None
    control = StageControl()
    previous = signal.signal(signal.SIGINT, lambda *_: control.stop())
    try:
        report = fit_project(project, cfg, focal=args.focal, restart=args.restart, control=control, device=device)
    except StopRequested:
        print("morf fit: stopped; the last completed stage is saved, run again to resume")
        return 130
    finally:
        signal.signal(signal.SIGINT, previous)
    fits = report.fits
    if report.up_to_date:
        print(f"fits in {project.fits_dir} are complete for this configuration (use --restart to fit again)")
    elif report.resumed_from:
        print(f"resumed after stage {report.resumed_from}")
    n = fits.num_frames
    if report.spacing:
        print(report.spacing)
    print(f"fitted {n} frames in {report.seconds:.1f} s ({n / max(report.seconds, 1e-9):.1f} frames/s)")
    # numpy's median, as filter.json records it (torch's is the lower middle value of an even count)
    print(f"keypoint residual: median {float(np.nanmedian(fits.keypoint_residual_px)):.1f} px")
    if fits.label_swapped is not None and fits.label_swapped.any():
        print(f"{int(fits.label_swapped.sum())} frames fitted as seen from the back with the keypoints' left and "
              "right exchanged (no face found where the labels said front)")
    if fits.landmark_residual_px is not None:
        face, left, right = (np.nanmedian(c) if not np.isnan(c).all() else float("nan")
                             for c in fits.landmark_residual_px.T)
        print(f"head and hands turned to the face and hand landmarks: median residual face {face:.1f} px, "
              f"hands {left:.1f} / {right:.1f} px (left / right)")
    if not np.isnan(fits.silhouette_iou).all():
        line = f"silhouette IoU: median {float(np.nanmedian(fits.silhouette_iou)):.3f}"
        if fits.offsets is not None and fits.silhouette_iou_body is not None:
            line += (f" with clothing offsets (mean {1000 * float(fits.offsets.mean()):.1f} mm), "
                     f"{float(np.nanmedian(fits.silhouette_iou_body)):.3f} body alone")
        print(line)
    print(f"frame filter: {len(report.rejected)} of {n} frames rejected")
    for i, reason in list(report.rejected.items())[:10]:
        print(f"  {i:6d}  {reason}")
    if len(report.rejected) > 10:
        print(f"  ... and {len(report.rejected) - 10} more (see {project.fits_dir / 'filter.json'})")
    return 0
