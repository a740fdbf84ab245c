"""``morf bench NAME --out DIR``: the benchmarks behind every number in docs/.

Each benchmark's command line is a module ``morf/cli/bench/<name>.py`` with
``add_arguments(parser)`` and ``run(args) -> int``: it turns the parsed options into a call of the
library's benchmark in ``morf/bench/``, which writes ``DIR/<name>.json`` plus a Markdown table.
"""

from __future__ import annotations

import argparse
import importlib
import subprocess
import sys

# The classes of morf.machine.cpuid_mask.CLASSES (a test keeps the two equal): named here so that
# building morf's parser, which every command does, loads no machine probe.
CPU_CLASSES = ("avx2", "avx512-vnni")

BENCHMARKS = {
    "fitting": "mesh fitting against ground truth, with the paper's ablation",
    "quality": "avatar quality on held-out frames and novel poses, over seeds, against the RGB floor",
    "render": "live playback speed at 640x640 (GL rasterization + int8 renderer)",
    "pareto": "speed against accuracy over model sizes",
    "stability": "quality as nuisances grow, per method",
    "step": "seconds per training step with bfloat16 autocast on and off (what this CPU gets)",
    "resume": "kill -9 at random moments of 'morf run', run it again: the same avatar as an uninterrupted run",
    "web": "the avatar in a web page: fps at 640x640 in headless Chromium, per stage, and at the adaptive size",
}
# Benchmarks of the desktop app: name -> (module run with ``python -m``, help). They run in their own
# process, so the library never imports studio/ (and the app gets a fresh GLFW and GL state).
APP_BENCHMARKS = {
    "studio": ("studio.bench", "the studio window playing an avatar: live render fps, UI frame times, CPU split"),
}


def add_parser(sub):
    p = sub.add_parser("bench", help="run a benchmark and write JSON + Markdown results")
    p.add_argument("--cpu-as", choices=CPU_CLASSES, default=None, metavar="CLASS",
                   help="run the benchmark with this CPU's CPUID masked to a smaller class, so onnxruntime, numba and "
                        "llvmpipe pick that class's kernels (Linux, CPUs with cpuid_fault; needs a C compiler): avx2 "
                        "(AVX2 + FMA only: no AVX-512, VNNI or AMX) or avx512-vnni (AVX-512 with VNNI, no AMX, no "
                        "native bf16); docs/playback.md")
    bsub = p.add_subparsers(dest="bench", metavar="NAME")
    for name, help_text in BENCHMARKS.items():
        module = importlib.import_module(f"morf.cli.bench.{name}")
        bp = bsub.add_parser(name, help=help_text)
        module.add_arguments(bp)
        bp.set_defaults(_bench_run=module.run)
    for name, (module_name, help_text) in APP_BENCHMARKS.items():
        # every argument (--help too) goes to the app's own parser: '+' keeps argparse from reading '-' options here
        bp = bsub.add_parser(name, help=help_text, add_help=False, prefix_chars="+")
        bp.add_argument("app_args", nargs=argparse.REMAINDER)
        bp.set_defaults(_bench_run=lambda args, m=module_name: subprocess.call([sys.executable, "-m", m,
                                                                                *args.app_args]))
    return p


def run(args) -> int:
    if not getattr(args, "_bench_run", None):
        print("usage: morf bench {" + ",".join([*BENCHMARKS, *APP_BENCHMARKS]) + "} --out DIR")
        return 1
    if args.cpu_as:
        from morf.machine.cpuid_mask import run_as

        run_as(args.cpu_as)  # re-runs this command under the mask unless it already is
    return int(args._bench_run(args) or 0)
