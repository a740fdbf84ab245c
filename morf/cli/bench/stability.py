"""``morf bench stability --out DIR``: the command line of :mod:`morf.bench.stability`."""

from __future__ import annotations


def add_arguments(p) -> None:
    from morf.bench.stability import FIT_SERIES, METHODS, SERIES
    from morf.presets import default_preset, presets_of
    from morf.scale.ray_runtime import add_arguments as ray_arguments

    p.add_argument("--out", required=True, help="folder for stability.json, stability.md, charts, captures")
    p.add_argument("--preset", choices=tuple(presets_of("stability")), default=default_preset("stability"),
                   help="tiny: CI (seconds per point)")
    p.add_argument("--series", default=",".join(SERIES + FIT_SERIES),
                   help="comma-separated subset of: " + ", ".join(SERIES + FIT_SERIES))
    p.add_argument("--methods", default=",".join(METHODS), help="comma-separated subset of: " + ", ".join(METHODS))
    p.add_argument("--repeats", type=int, default=1,
                   help="trainings per point with seeds 0..N-1 (means, spread, and a noise-aware breakdown)")
    ray_arguments(p, "cores each training holds (default 1: as many trainings at once as there are cores)")


def run(args) -> int:
    from pathlib import Path

    from morf.bench.stability import run_stability
    from morf.cli.bench.lists import comma_list
    from morf.scale.ray_runtime import options_from_args

    run_stability(Path(args.out), args.preset, comma_list(args.series), comma_list(args.methods),
                  repeats=args.repeats, ray=options_from_args(args), workers=args.workers,
                  cpus_per_task=args.cpus_per_task)
    return 0
