"""``morf eval PROJECT``: score trained avatars on frames they never trained on, beside the RGB floor.

Writes ``eval.json``, a comparison sheet, space-time (y-t) slices and enlarged head crops per target
into ``--out`` (default ``PROJECT/eval``) and prints a table; LPIPS with ``--lpips PATH --vgg PATH`` (or their
environment variables). See :mod:`morf.evaluate.project_eval`.
"""

from __future__ import annotations

from morf.cli.options import add_force_option, add_weights_option


def add_parser(sub):
    p = sub.add_parser("eval", help="score trained avatars on held-out frames beside the RGB floor")
    p.add_argument("project", help="capture project folder with finished runs")
    p.add_argument("--run", action="append", default=[], metavar="NAME",
                   help="a run under PROJECT/runs to score (repeatable; default: every finished run)")
    p.add_argument("--out", default=None, help="output folder (default: PROJECT/eval)")
    add_force_option(p, "write into an existing non-empty --out folder, replacing only the files morf eval writes")
    p.add_argument("--floor", action="store_true", default=True,
                   help="include the RGB floor of each hold-out setting, built in seconds when missing (default)")
    p.add_argument("--no-floor", dest="floor", action="store_false", help="leave the RGB floor out")
    p.add_argument("--resolution", default=None, metavar="R",
                   help="evaluation side in pixels (a multiple of the renderer's), or 'native' for the crop's size "
                        "in the capture (default: each run's training resolution)")
    add_weights_option(p, "--lpips", "LPIPS v0.1 linear layers, the lpips package's weights/v0.1/vgg.pth (default: "
                                     "$MORF_LPIPS_WEIGHTS; neither: LPIPS is null). Needs the VGG-16 weights too")
    add_weights_option(p, "--vgg", "torchvision's VGG-16 weights (vgg16-397923af.pth) for LPIPS (default: "
                                   "$MORF_VGG16_WEIGHTS)")
    p.add_argument("--refine-poses", action="store_true",
                   help="refine each frame's body pose against the real frame with each run's avatar frozen before "
                        "scoring (every run alike, the floor included): scores the appearance without the fit's "
                        "pose error, as monocular-avatar papers evaluate; minutes per run")
    p.add_argument("--seen", action="store_true",
                   help="also score each run on the training frames nearest its held-out ones (target seen-kK): "
                        "how much of its error it makes on frames it saw, and how much on frames it did not")
    p.add_argument("--no-detail", dest="detail", action="store_false",
                   help="skip the detail scores (person, head and hands at native size: SSIM at the best shift "
                        "within +-4 px, GMSD, high-frequency ratio) and the head crops")
    return p


def parse_resolution(value: str | None):
    from morf.errors import InputError

    if value is None or value == "native":
        return value
    try:
        side = int(value)
    except ValueError:
        raise InputError(f"--resolution must be a number of pixels or 'native', got {value!r}") from None
    if side < 1:
        raise InputError(f"--resolution must be positive, got {side}")
    return side


def run(args) -> int:
    from pathlib import Path

    from morf.capture.project import CaptureProject
    from morf.io.names import check_name

    project = CaptureProject.open(args.project)
    for name in args.run:
        check_name(name, "run name")

    from morf.evaluate.project_eval import EvalConfig, evaluate_project, format_table

    cfg = EvalConfig(runs=tuple(args.run), out=args.out, floor=args.floor,
                     resolution=parse_resolution(args.resolution), lpips=args.lpips, vgg=args.vgg,
                     refine_poses=args.refine_poses, detail=args.detail, seen=args.seen, force=args.force)
    result = evaluate_project(project, cfg, say=print)
    print(format_table(result))
    out = Path(args.out) if args.out else Path(project.root) / "eval"
    images = sum(2 + (t.heads is not None) for t in result.targets.values())
    print(f"wrote {out / 'eval.json'} and {images} images")
    return 0
