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
from dataclasses import dataclass
from pathlib import Path

STAGES = ("skinning", "raster", "readback", "renderer", "composite")


@dataclass(frozen=True)
class WebOptions:
    """What ``morf bench web`` measures.

    Fields:
        avatar: an avatar folder (``morf export``) or a web folder (``morf web``); out: folder for
        web.json and web.md; size: output side in pixels; frames: timed frames a measurement;
        isolation: serve with the COOP/COEP headers (False: as a plain static host, one WASM
        thread); threads: onnxruntime-web threads (0: the page's choice); tail: auto | js | webgl,
        where the renderer's tail runs; timeout: seconds to wait for the page.
    """

    avatar: str
    out: str
    size: int = 640
    frames: int = 60
    isolation: bool = True
    threads: int = 0
    tail: str = "auto"
    timeout: float = 900.0


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


def run_web(opts: WebOptions) -> dict:
    """Play the avatar in headless Chromium and write web.json and web.md; returns web.json's content."""
    from morf.bench.common import machine_info, write_results
    from morf.errors import InputError
    from morf.web.browser import missing_browser, run_page
    from morf.web.build import folder_bytes

    why = missing_browser()
    if why:
        raise InputError(why)
    if not 32 <= opts.size <= 4096 or opts.frames < 1:
        raise InputError(f"--size must be 32-4096 and --frames positive, got {opts.size} and {opts.frames}")
    avatar = Path(opts.avatar)
    if not avatar.is_dir():
        raise InputError(f"avatar folder not found: {avatar}")
    with tempfile.TemporaryDirectory(prefix="morf-bench-web-") as tmp:
        folder = _web_folder(avatar, Path(tmp))
        query = f"bench={opts.frames}&size={opts.size}" + (f"&threads={opts.threads}" if opts.threads else "") \
            + ("" if opts.tail == "auto" else f"&tail={opts.tail}")
        load_before = os.getloadavg()
        t0 = time.monotonic()
        page = run_page(folder, query, isolation=opts.isolation, timeout=opts.timeout)
        seconds = time.monotonic() - t0
        load_after = os.getloadavg()
        size = folder_bytes(folder)
    if "error" in page:
        raise InputError(f"the page failed: {page['error'].splitlines()[0]}")
    page.pop("requests", None)
    result = {"avatar": str(avatar), "folder": str(folder), "folder_mb": size / 1e6, "frames": opts.frames,
              "page": page, "machine": machine_info(), "load_before": load_before, "load_after": load_after,
              "seconds": round(seconds, 1)}
    md = _markdown(result)
    path = write_results(opts.out, "web", result, md)
    print(md)
    print(f"wrote {path}")
    return result
