"""``morf bench render --out DIR [--avatar DIR]``: the command line of :mod:`morf.bench.render`."""

from __future__ import annotations

import sys


def add_arguments(p) -> None:
    p.add_argument("--out", required=True, help="folder for render.json and render.md")
    p.add_argument("--avatar", default=None, help="an exported avatar folder (default: synthetic avatars)")
    p.add_argument("--size", type=int, default=640)
    p.add_argument("--frames", type=int, default=60, help="timed frames per measurement")
    p.add_argument("--no-variants", action="store_true", help="only the default renderer (no size variants)")
    p.add_argument("--raster", choices=("auto", "gl", "cpu"), default="auto",
                   help="the players' rasterization: GL, the CPU loops (numba), or auto (the CPU loops under "
                        "software GL, GL on a GPU; MORF_RASTER sets it too)")
    p.add_argument("--no-amx", action="store_true",
                   help="refuse AMX to the measurement (Linux x86-64): what this CPU gets without it")


def run(args) -> int:
    from morf.bench.render import RenderOptions, run_render

    # the command as typed, recorded in render.json beside the numbers
    command = "morf " + " ".join(sys.argv[1:]) if sys.argv[1:2] == ["bench"] else "morf bench render"
    run_render(RenderOptions(args.out, args.avatar, args.size, args.frames, variants=not args.no_variants,
                             raster=args.raster, no_amx=args.no_amx, command=command))
    return 0
