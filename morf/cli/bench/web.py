"""``morf bench web AVATAR --out DIR``: the command line of :mod:`morf.bench.web`."""

from __future__ import annotations


def add_arguments(p) -> None:
    p.add_argument("avatar", help="an exported avatar folder (morf export) or a web folder (morf web)")
    p.add_argument("--out", required=True, help="folder for web.json and web.md")
    p.add_argument("--size", type=int, default=640, help="output side in pixels (default 640)")
    p.add_argument("--frames", type=int, default=60, help="timed frames per measurement")
    p.add_argument("--no-isolation", action="store_true",
                   help="serve without the COOP/COEP headers, as a plain static host does (one WASM thread)")
    p.add_argument("--threads", type=int, default=0, help="onnxruntime-web threads (0: the page's choice)")
    p.add_argument("--tail", choices=("auto", "js", "webgl"), default="auto",
                   help="where the renderer's tail runs: JavaScript, WebGL passes, or the page's choice")
    p.add_argument("--timeout", type=float, default=900.0, help="seconds to wait for the page")
    p.add_argument("--crop", default="", help="'off': the renderer on the whole frame; N: N pixels around the person "
                   "(default: the page's margin)")
    p.add_argument("--proxy", action="store_true", help="onnxruntime-web in its worker (the renderer beside the next frame's GL)")
    p.add_argument("--compare", default="", metavar="KEY:A,B",
                   help="two settings of a page option measured in turn instead of the bench: skin:cpu,gpu, "
                        "canvas:2d,gl, overlap:on,off, spin:on,off (onnxruntime-web's idle threads spinning or "
                        "sleeping), graph:A,B (two forms of the renderer graph, A and B from matmul, conv, fused, "
                        "web, each with the colour fill in the graph, and shipped, the folder's own graph with the "
                        "fill in the page; AVATAR an exported avatar folder), or 'crop' (the person's window against the whole frame)")
    p.add_argument("--block", type=int, default=1, help="frames per turn of --compare (default 1)")
    p.add_argument("--profile", action="store_true",
                   help="onnxruntime-web's per-node profile over --frames frames instead of the bench (kernel ms a "
                        "run by operator and by node)")
    p.add_argument("--played", action="store_true",
                   help="--compare the frames as the page plays them (wall times) instead of each stage waited for")


def run(args) -> int:
    from morf.bench.web import WebOptions, run_web

    run_web(WebOptions(args.avatar, args.out, args.size, args.frames, isolation=not args.no_isolation,
                       threads=args.threads, tail=args.tail, timeout=args.timeout, crop=args.crop,
                       proxy=args.proxy, compare=args.compare, block=args.block, played=args.played,
                       profile=args.profile))
    return 0
