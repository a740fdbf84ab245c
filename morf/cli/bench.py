"""``morf bench NAME --out DIR``: the benchmarks behind every number in docs/.

Each benchmark is a module ``morf/bench/<name>.py`` with ``add_arguments(parser)`` and
``run(args) -> int``; it writes ``DIR/<name>.json`` plus a Markdown table.
"""

from __future__ import annotations

import importlib

BENCHMARKS = {
    "fitting": "mesh fitting against ground truth, with the paper's ablation",
    "quality": "avatar quality on held-out frames and novel poses, over seeds, against the RGB floor",
    "render": "live playback speed at 640x640 (GL rasterization + int8 renderer)",
    "pareto": "speed against accuracy over model sizes",
    "stability": "quality as nuisances grow, per method",
    "step": "seconds per training step with bfloat16 autocast on and off (what this CPU gets)",
}


def add_parser(sub):
    p = sub.add_parser("bench", help="run a benchmark and write JSON + Markdown results")
    bsub = p.add_subparsers(dest="bench", metavar="NAME")
    for name, help_text in BENCHMARKS.items():
        try:
            module = importlib.import_module(f"morf.bench.{name}")
        except ModuleNotFoundError as e:
            if e.name == f"morf.bench.{name}":
                continue
            raise
        bp = bsub.add_parser(name, help=help_text)
        module.add_arguments(bp)
        bp.set_defaults(_bench_run=module.run)
    return p


def run(args) -> int:
    if not getattr(args, "_bench_run", None):
        print("usage: morf bench {" + ",".join(BENCHMARKS) + "} --out DIR")
        return 1
    return int(args._bench_run(args) or 0)
