"""``morf bench quality --out DIR``: the command line of :mod:`morf.bench.quality`."""

from __future__ import annotations


def add_arguments(p) -> None:
    from morf.bench.quality import DEFAULT_METHODS, METHODS
    from morf.presets import presets_of

    p.add_argument("--out", required=True, help="output folder for quality.json / quality.md and the images")
    p.add_argument("--preset", choices=tuple(presets_of("train")), default="cpu", help="training preset (tiny: CI)")
    p.add_argument("--project", default=None,
                   help="an existing synthetic capture project (default: make and fit one in OUT/capture)")
    p.add_argument("--methods", default=DEFAULT_METHODS,
                   help=f"comma-separated methods from {', '.join(METHODS)}; the rgb floor is always included "
                        f"(default {DEFAULT_METHODS})")
    p.add_argument("--seeds", type=int, default=1, help="trainings per learned method, seeds 0..N-1 (default 1)")
    p.add_argument("--holdout", type=int, default=5,
                   help="keep the usable capture frames numbered 0, K, 2K, ... out of training and score on them "
                        "(default 5; 0: none)")
    p.add_argument("--steps", type=int, default=None, help="override the preset's training steps")
    p.add_argument("--fits", choices=("fits", "ground-truth", "auto"), default="fits",
                   help="body fits to train on (default: fitted bodies; the capture is fitted when it has none)")
    p.add_argument("--vgg", default=None, help="VGG-16 weights for the perceptual loss (else feature matching) "
                                               "and for LPIPS")
    p.add_argument("--lpips", default=None, metavar="PATH",
                   help="LPIPS v0.1 linear layers (the lpips package's weights/v0.1/vgg.pth; default "
                        "$MORF_LPIPS_WEIGHTS) to score LPIPS with; needs the VGG-16 weights too (else null)")
    p.add_argument("--refine-poses", action="store_true",
                   help="score with each frame's pose refined against the frame, every run alike (morf eval "
                        "--refine-poses; docs/evaluation.md)")


def run(args) -> int:
    from pathlib import Path

    from morf.bench.quality import parse_methods, run_quality

    run_quality(Path(args.out), args.preset, parse_methods(args.methods), seeds=args.seeds, holdout=args.holdout,
                steps=args.steps, fits=args.fits, vgg=args.vgg, lpips=args.lpips, project_path=args.project,
                refine_poses=args.refine_poses)
    return 0
