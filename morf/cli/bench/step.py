"""``morf bench step --out DIR``: the command line of :mod:`morf.bench.step`."""

from __future__ import annotations


def add_arguments(p) -> None:
    from morf.presets import presets_of

    p.add_argument("--out", required=True, help="output folder for step.json / step.md")
    p.add_argument("--project", default=None, help="a capture project (default: build the default synthetic one)")
    p.add_argument("--preset", choices=tuple(presets_of("train")), default="cpu", help="training preset to time")
    p.add_argument("--method", choices=("morf", "stylepeople", "anr"), default="morf")
    p.add_argument("--steps", type=int, default=40, help="timed steps per setting")
    p.add_argument("--warmup", type=int, default=6, help="untimed steps first")


def run(args) -> int:
    from morf.bench.step import StepOptions, run_step

    run_step(StepOptions(args.out, args.project, args.preset, args.method, args.steps, args.warmup))
    return 0
