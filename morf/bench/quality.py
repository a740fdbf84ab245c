"""``morf bench quality --out DIR [--preset tiny|cpu]``: avatar quality on novel poses.

Trains morf, stylepeople and anr with the same preset on a synthetic capture (the default
synthetic capture, or the tiny one with ``--preset tiny``; ``--project`` uses an existing
synthetic project) and renders its hold-out sequence (``ground_truth/holdout``: arm raises, hip
sway, steps) with the ground-truth hold-out poses. Writes ``DIR/quality.json``
``{"methods": {"morf": {psnr, ssim, lpips, temporal, train_minutes, ...}, ...}}`` and
``DIR/quality.md``.

Metrics (morf/avatar/metrics.py, via ``evaluate_frames``): the render and the frame are both
composited over the capture's backdrop colour (median outside the person masks), as the player
composites; PSNR and SSIM over the whole image and over the person only; ``temporal`` is the weight-free temporal
flicker (lower is better); LPIPS is null (no LPIPS weights on this machine). Training runs live in
``PROJECT/runs/bench-<method>-<preset>`` and resume if the benchmark is interrupted.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

METHODS = ("morf", "stylepeople", "anr")


def add_arguments(p):
    p.add_argument("--out", required=True, help="output folder for quality.json / quality.md")
    p.add_argument("--preset", choices=("tiny", "cpu", "gpu"), default="cpu", help="training preset (tiny: CI)")
    p.add_argument("--project", default=None,
                   help="an existing synthetic capture project (default: build one in OUT/capture)")
    p.add_argument("--methods", default=",".join(METHODS), help="comma-separated methods to compare")
    p.add_argument("--steps", type=int, default=None, help="override the preset's training steps")
    p.add_argument("--fits", choices=("ground-truth", "fits", "auto"), default="ground-truth",
                   help="body fits to train on (default: the capture's ground truth)")
    p.add_argument("--vgg", default=None, help="VGG-16 weights for the perceptual loss (else feature matching)")


def _project(args, out: Path):
    from morf.capture.project import CaptureProject
    from morf.errors import InputError

    if args.project:
        project = CaptureProject.open(args.project)
        if not (project.ground_truth_dir / "holdout.npz").is_file():
            raise InputError(f"{project.root} has no hold-out sequence (a synthetic capture is needed)")
        return project
    root = out / "capture"
    if CaptureProject.is_project(root):
        return CaptureProject.open(root)
    from morf.synth.capture import make_synthetic_capture
    from morf.synth.config import synth_config

    return make_synthetic_capture(root, synth_config("tiny" if args.preset == "tiny" else "default"), overwrite=True)


def run(args) -> int:
    from morf.avatar.trained import load_trained_avatar
    from morf.bench.common import machine_info, markdown_table, write_results
    from morf.body import load_body_model
    from morf.errors import InputError
    from morf.train.config import preset
    from morf.train.data import build_holdout_frames
    from morf.train.plateau import run_plateau
    from morf.train.project_run import evaluate_frames, train_project

    out = Path(args.out)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    bad = [m for m in methods if m not in METHODS]
    if bad or not methods:
        raise InputError(f"unknown method(s) {bad}; choose from {', '.join(METHODS)}")
    model = load_body_model("anny")
    project = _project(args, out)
    results, rows = {}, []
    for method in methods:
        overrides = {"steps": args.steps} if args.steps else {}
        cfg = preset(args.preset, method, **overrides)
        t0 = time.time()
        res = train_project(project, cfg, f"bench-{method}-{args.preset}", fits_source=args.fits, vgg=args.vgg,
                            model=model)
        avatar = load_trained_avatar(res.run_dir)
        holdout = build_holdout_frames(project, model, avatar.camera, avatar.shape.numpy())
        if holdout is None:
            raise InputError(f"{project.root} has no hold-out sequence")
        m = evaluate_frames(avatar, holdout)
        m.update({"lpips": None, "train_minutes": res.train_minutes, "steps": res.step,
                  "wall_minutes_this_session": (time.time() - t0) / 60})
        plat = run_plateau(res.run_dir)
        m["plateau"] = plat
        m["plateau_minutes"] = None if plat is None else plat["minutes"]
        results[method] = m
        rows.append({"method": method, **m})
        print(f"{method}: PSNR {m['psnr']:.2f} dB (person {m['psnr_person']:.2f}), SSIM {m['ssim']:.4f}, "
              f"temporal {m['temporal']:.5f}, {res.train_minutes:.1f} min")
    checks = {}
    if "morf" in results and "stylepeople" in results:
        a, b = results["morf"], results["stylepeople"]
        checks = {"temporal_gain_vs_stylepeople": 1 - a["temporal"] / b["temporal"] if b["temporal"] else None,
                  "psnr_delta_vs_stylepeople_db": a["psnr"] - b["psnr"]}
        checks["target_temporal_10pct_better"] = bool(checks["temporal_gain_vs_stylepeople"] is not None
                                                      and checks["temporal_gain_vs_stylepeople"] >= 0.10)
        checks["target_psnr_within_0p5db"] = bool(checks["psnr_delta_vs_stylepeople_db"] >= -0.5)
    if results.get("morf", {}).get("plateau_minutes") is not None:
        checks["morf_plateau_minutes"] = results["morf"]["plateau_minutes"]
        checks["target_plateau_within_30min"] = bool(results["morf"]["plateau_minutes"] <= 30)
    result = {"benchmark": "quality", "preset": args.preset, "project": str(project.root), "fits": args.fits,
              "holdout_frames": results[methods[0]]["frames"], "methods": results, "checks": checks,
              "machine": machine_info()}
    cols = ["method", "psnr", "psnr_person", "ssim", "ssim_person", "lpips", "temporal", "train_minutes",
            "plateau_minutes", "steps"]
    # the load average says how much of the 2-core CPU the run actually had
    result["load_average"] = list(os.getloadavg())
    md = (f"# Avatar quality on novel-pose hold-out ({args.preset} preset)\n\n"
          + markdown_table(rows, cols, "{:.4g}")
          + "\nPSNR in dB (higher is better); SSIM (higher is better); temporal = flicker, lower is better.\n")
    if checks:
        md += "\n" + "\n".join(f"- {k}: {v}" for k, v in checks.items()) + "\n"
    path = write_results(out, "quality", result, md)
    print(f"wrote {path}")
    return 0
