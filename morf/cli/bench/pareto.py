"""``morf bench pareto --out DIR``: the command line of :mod:`morf.bench.pareto` and, with
``--auto-check``, of :mod:`morf.bench.auto_check`."""

from __future__ import annotations


def add_arguments(p) -> None:
    from morf.presets import default_preset, presets_of
    from morf.scale.ray_runtime import add_arguments as ray_arguments

    p.add_argument("--out", required=True, help="folder for pareto.json, pareto.md, charts and per-point results")
    p.add_argument("--preset", choices=tuple(presets_of("sweep")), default=default_preset("sweep"),
                   help="sweep size: tiny (CI, seconds), quick (about an hour), default (many hours)")
    p.add_argument("--project", default=None,
                   help="an existing synthetic capture (default: make one in OUT); with --auto-check, "
                        "scene=PATH[,scene=PATH...] names one per scene")
    p.add_argument("--scene", choices=("print", "plain", "loose"), default="print",
                   help="synthetic scene when a capture is made")
    p.add_argument("--axes", default=None, help="comma-separated subset of the sweep's knobs (default: all)")
    p.add_argument("--points", default=None,
                   help="comma-separated points to measure (e.g. renderer-stem4_b32; default: all on --axes); "
                        "points measured earlier in --out on the same capture are kept")
    p.add_argument("--auto-check", action="store_true",
                   help="check --preset auto on the plain, print and loose scenes instead of one sweep")
    p.add_argument("--scenes", default="plain,print,loose",
                   help="--auto-check: comma-separated scenes")
    p.add_argument("--seeds", type=int, default=1,
                   help="train every point with this many seeds (base seed, +1, ...) and chart the means; "
                        "with --auto-check judge on the means (default 1)")
    ray_arguments(p, "cores each training holds (default: all of this machine's, one training at a time, as the "
                     "training-minutes axis assumes; fewer train several at once)", default_cpus=None)


def _auto_check(args, points: list[str] | None, ray) -> None:
    from pathlib import Path

    from morf.bench.auto_check import auto_check
    from morf.cli.bench.lists import comma_list
    from morf.errors import InputError

    if args.workers is not None or args.cpus_per_task is not None:
        raise InputError("--workers and --cpus-per-task do not apply to --auto-check (its sweeps train with "
                         "the defaults); --address does")
    auto_check(Path(args.out), args.preset, scenes=comma_list(args.scenes), project_path=args.project, points=points,
               seeds=args.seeds, ray=ray)


def run(args) -> int:
    from pathlib import Path

    from morf.bench.pareto import run_sweep
    from morf.cli.bench.lists import comma_list
    from morf.scale.ray_runtime import options_from_args

    points = comma_list(args.points)
    ray = options_from_args(args)
    if args.auto_check:
        _auto_check(args, points, ray)
        return 0
    run_sweep(Path(args.out), args.preset, args.scene, args.project, comma_list(args.axes), points=points,
              seeds=args.seeds, ray=ray, workers=args.workers, cpus_per_task=args.cpus_per_task)
    return 0
