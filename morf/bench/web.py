"""``morf bench web AVATAR --out DIR``: the avatar in a web page, end to end, in headless Chromium.

AVATAR is an avatar folder (``morf export``; its web folder is written to a temporary folder
first) or a web folder (``morf web``). The page (resources/web/harness.js, ``?bench=N``) plays
the first motion at SIZE x SIZE: N frames as the page plays them (pose in, image on the canvas;
frame t's renderer overlapping frame t+1's GL work where onnxruntime-web runs in its worker) give
the fps, N frames one after another the sequential fps, N more with each stage waited for the
stages' times and shares
(skinning: bone matrices + upload; raster: GPU skinning + neural rasterization; readback;
renderer: onnxruntime-web; composite: tail + composite + canvas). Then the page picks its
adaptive size from the rate it measures, as it does for a user, and the fps there is measured.
The report names the threads, the ORT backend, whether the page was cross-origin isolated, the
WebGL renderer, the folder's size, and the load average of the machine while it ran (other
processes on a 2-core machine change every number here).
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

STAGES = ("skinning", "raster", "readback", "renderer", "composite")


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


def _web_folder(avatar: Path, tmp: Path) -> Path:
    if (avatar / "player.json").is_file():
        return avatar
    from morf.web.build import build_web_folder

    return build_web_folder(avatar, tmp / "web", command="morf bench web").path


def _markdown(r: dict) -> str:
    from morf.bench.common import markdown_table

    env = r["page"]
    rows = [{"stage": s, "ms": r["page"]["stages_ms"][s], "share": f"{100 * r['page']['shares'][s]:.0f} %"} for s in STAGES]
    adaptive = env["adaptive"]
    steps = "; ".join(f"{s['from']} px at {s['fps']:.1f} fps -> {s['to']} px" for s in adaptive["steps"]) or "none"
    return (f"# The avatar in a web page\n\n"
            f"{r['machine']['cpu']}, {r['machine']['cores']} cores; {env['user_agent']}\n\n"
            f"WebGL: {env['webgl']}; onnxruntime-web {env['backend']}, {env['threads']} thread(s), "
            f"cross-origin isolated: {env['isolated']}; renderer {env['renderer']['precision']} "
            f"({env['renderer']['mode']}), tail in {env.get('tail')}\n\n"
            f"Load average while it ran: {r['load_before'][0]:.1f} before, {r['load_after'][0]:.1f} after "
            f"(1 min; 2 cores: above 2 other processes share the CPU)\n\n"
            f"**{env['size']} x {env['size']}: {env['fps']:.1f} fps end to end** as the page plays "
            f"({env['ms_per_frame']:.1f} ms a frame, {r['frames']} frames; the renderer proxied to a worker: "
            f"{env.get('proxy')}); one frame after another: {env['sequential_fps']:.1f} fps; with each stage waited "
            f"for: {env['staged_fps']:.1f} fps\n\n"
            + markdown_table(rows, ["stage", "ms", "share"], "{:.1f}") +
            f"\nAdaptive size: **{adaptive['size']} x {adaptive['size']}: {adaptive['fps']:.1f} fps** "
            f"(steps: {steps})\n\nWeb folder: {r['folder_mb']:.2f} MB ({r['folder']})\n")


def run(args) -> int:
    from morf.bench.common import machine_info, write_results
    from morf.errors import InputError
    from morf.web.browser import missing_browser, run_page
    from morf.web.build import folder_bytes

    why = missing_browser()
    if why:
        raise InputError(why)
    if not 32 <= args.size <= 4096 or args.frames < 1:
        raise InputError(f"--size must be 32-4096 and --frames positive, got {args.size} and {args.frames}")
    avatar = Path(args.avatar)
    if not avatar.is_dir():
        raise InputError(f"avatar folder not found: {avatar}")
    with tempfile.TemporaryDirectory(prefix="morf-bench-web-") as tmp:
        folder = _web_folder(avatar, Path(tmp))
        query = f"bench={args.frames}&size={args.size}" + (f"&threads={args.threads}" if args.threads else "") \
            + ("" if args.tail == "auto" else f"&tail={args.tail}")
        load_before = os.getloadavg()
        t0 = time.monotonic()
        page = run_page(folder, query, isolation=not args.no_isolation, timeout=args.timeout)
        seconds = time.monotonic() - t0
        load_after = os.getloadavg()
        size = folder_bytes(folder)
    if "error" in page:
        raise InputError(f"the page failed: {page['error'].splitlines()[0]}")
    page.pop("requests", None)
    result = {"avatar": str(avatar), "folder": str(folder), "folder_mb": size / 1e6, "frames": args.frames,
              "page": page, "machine": machine_info(), "load_before": load_before, "load_after": load_after,
              "seconds": round(seconds, 1)}
    md = _markdown(result)
    path = write_results(args.out, "web", result, md)
    print(md)
    print(f"wrote {path}")
    return 0
