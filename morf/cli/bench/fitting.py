"""``morf bench fitting --out DIR``: the command line of :mod:`morf.bench.fitting`."""

from __future__ import annotations


def add_arguments(p) -> None:
    from morf.bench.fitting import ABLATION

    p.add_argument("--out", required=True, help="folder for fitting.json and fitting.md")
    p.add_argument("--project", default=None, help="an existing synthetic capture (default: make one in OUT/capture)")
    p.add_argument("--preset", default="default", help="synthetic capture preset when one is made: tiny | default")
    p.add_argument("--frames", type=int, default=None, help="override the capture's frame count when one is made")
    p.add_argument("--fit-preset", default="default", help="fit preset the ablation starts from")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help="change a setting of the fit preset before the ablation (repeatable), as 'morf fit --set'")
    p.add_argument("--configs", default=",".join(ABLATION), help="comma-separated subset of: " + ", ".join(ABLATION))
    p.add_argument("--command-runs", type=int, default=0,
                   help="also time the whole 'morf fit CAPTURE --restart' command this many times, each in a "
                        "fresh process on a copy of the capture: start-up, evaluation and overlays counted")


def run(args) -> int:
    from morf.bench.fitting import FittingOptions, run_fitting

    configs = tuple(k.strip() for k in args.configs.split(",") if k.strip())
    run_fitting(FittingOptions(args.out, args.project, args.preset, args.frames, args.fit_preset, tuple(args.set),
                               configs, args.command_runs))
    return 0
