"""``morf bench web AVATAR --out DIR``: the avatar in a web page, end to end, in headless Chromium.

AVATAR is an avatar folder (``morf export``; its web folder is written to a temporary folder
first) or a web folder (``morf web``). The page (resources/web/harness.js, ``?bench=N``) plays
the first motion at SIZE x SIZE: N frames as the page plays them (pose in, image on the canvas;
frame t's renderer overlapping frame t+1's GL work where onnxruntime-web runs in its worker) give
the fps, N frames one after another the sequential fps, N more with each stage waited for the
stages' times and shares
(skinning: bone matrices + upload; raster: GPU skinning + neural rasterization; readback;
renderer: onnxruntime-web; composite: the colour fill + tail + composite + canvas). Then the page picks its
adaptive size from the rate it measures, as it does for a user, and the fps there is measured.
The report names the threads, the ORT backend, whether the page was cross-origin isolated, the
WebGL renderer, the folder's size, and the load average of the machine while it ran (other
processes on a 2-core machine change every number here).
"""

from __future__ import annotations

import os
import re
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
        where the renderer's tail runs; timeout: seconds to wait for the page; crop: "" (the page's
        margin around the person), "off" (the whole frame) or a margin in pixels; proxy:
        onnxruntime-web in its worker; compare: "KEY:A,B", two settings of one page option measured
        in turn (skin:cpu,gpu, canvas:2d,gl, overlap:on,off; graph:A,B two forms of the renderer
        graph of :data:`morf.web.head_rewrite.GRAPH_FORMS` (the colour fill in the graph) or
        :data:`SHIPPED_FORM` (the fill in the page), on an avatar folder; "crop": the window
        against the whole frame) instead of the bench; block: frames per turn of a comparison; played: a comparison
        of the frames as the page plays them (wall times only) instead of each stage waited for;
        profile: onnxruntime-web's per-node profiler over ``frames`` frames (each stage waited
        for) instead of the bench: kernel milliseconds per run by operator and by node.
    """

    avatar: str
    out: str
    size: int = 640
    frames: int = 60
    isolation: bool = True
    threads: int = 0
    tail: str = "auto"
    timeout: float = 900.0
    crop: str = ""
    proxy: bool = False
    compare: str = ""
    block: int = 1
    played: bool = False
    profile: bool = False


def _web_folder(avatar: Path, tmp: Path) -> Path:
    if (avatar / "player.json").is_file():
        return avatar
    from morf.web.build import build_web_folder

    return build_web_folder(avatar, tmp / "web", command="morf bench web").path


def _graph_forms(opts: WebOptions, avatar: Path, tmp: Path) -> dict[str, Path]:
    """For ``--compare graph:A,B``: the renderer graph in forms A and B (:data:`morf.web.head_rewrite.GRAPH_FORMS`,
    from the graph the web export cuts) as files the page fetches from ``/graph/NAME.onnx``; {} otherwise."""
    if not opts.compare.startswith("graph:"):
        return {}
    from morf.errors import InputError
    from morf.playback.player import load_avatar
    from morf.web.head_rewrite import GRAPH_FORMS, web_rewrites
    from morf.web.web_avatar import web_renderer

    names = opts.compare.split(":", 1)[1].split(",")
    if any(n not in (*GRAPH_FORMS, SHIPPED_FORM) for n in names) or (avatar / "player.json").is_file():
        raise InputError(f"--compare graph:A,B takes an avatar folder (morf export) and forms of "
                         f"{', '.join((*GRAPH_FORMS, SHIPPED_FORM))}, got {opts.compare!r} on {avatar}")
    exported = load_avatar(avatar)
    cut = web_renderer(exported, page_fill=False).graph  # the forms keep the colour fill in the graph
    out = {}
    for name in names:
        out[f"/graph/{name}.onnx"] = tmp / f"graph_{name}.onnx"
        form = GRAPH_FORMS[name](cut) if name in GRAPH_FORMS else web_rewrites(web_renderer(exported).graph)
        out[f"/graph/{name}.onnx"].write_bytes(form)
    return out


# --compare graph:...: the graph the web folder ships (every rewrite, the colour fill in the page where it can be)
SHIPPED_FORM = "shipped"


def _query(opts: WebOptions) -> str:
    """The page's query for these options (harness.js, main.js)."""
    q = [f"bench={opts.frames}", f"size={opts.size}"]
    q += [f"threads={opts.threads}"] if opts.threads else []
    q += [] if opts.tail == "auto" else [f"tail={opts.tail}"]
    q += [f"crop={opts.crop}"] if opts.crop else []
    q += ["proxy=1"] if opts.proxy else []
    q += ["profile=1"] if opts.profile else []
    if opts.compare:
        q += [f"compare={opts.compare}", f"block={opts.block}"] + (["played=1"] if opts.played else [])
    return "&".join(q)


def _flags(opts: WebOptions) -> str:
    return (f"crop={opts.crop or 'the page default'}, proxy={'on' if opts.proxy else 'off'}, "
            + ("profile=on, " if opts.profile else "")
            + f"compare={opts.compare or 'none'}" + (f" (blocks of {opts.block}, {'played' if opts.played else 'each stage waited for'})"
                                                     if opts.compare else "") + f"; page query ?{_query(opts)}")


def _cpu_between(marks: list[dict], start: str, end: str) -> dict | None:
    """The browser's CPU seconds and the wall seconds between two of the page's marks."""
    m = {k["name"]: k for k in marks}
    if start not in m or end not in m or not m[start]["cpu"]:
        return None
    wall = m[end]["time"] - m[start]["time"]
    by = {k: m[end]["cpu"].get(k, 0.0) - v for k, v in m[start]["cpu"].items()}
    cpu = sum(by.values())
    out = {"cpu_s": cpu, "wall_s": wall, "cores": cpu / wall if wall > 0 else None, "by_process": by}
    if m[start].get("threads") and m[end].get("threads"):  # threads started in between count from 0
        out["by_thread"] = {k: v - m[start]["threads"].get(k, 0.0) for k, v in m[end]["threads"].items()}
    return out


def _cpu_by_setting(marks: list[dict]) -> dict:
    """A played comparison's browser CPU seconds per setting, summed over its turns (the page marks
    each turn "VALUE.TURN" and "VALUE.TURN.end"), per kind of process."""
    m = {k["name"]: k for k in marks}
    out: dict = {}
    for name, end in m.items():
        start = m.get(name[:-4]) if name.endswith(".end") else None
        if start is None or not start["cpu"]:
            continue
        acc = out.setdefault(name.split(".")[0], {"cpu_s": 0.0, "wall_s": 0.0, "by_process": {}})
        acc["wall_s"] += end["time"] - start["time"]
        for kind, v in end["cpu"].items():
            d = v - start["cpu"].get(kind, 0.0)
            acc["cpu_s"] += d
            acc["by_process"][kind] = acc["by_process"].get(kind, 0.0) + d
    return out


def _mesh_line(env: dict) -> str:
    """How the page chooses its mesh."""
    return ("mesh: the page's level of detail" if env.get("mesh_choice") == "auto"
            else f"mesh {env.get('mesh_choice') or env.get('mesh')}")


def _drawn(mesh: dict | None) -> str:
    """The mesh a part of the bench drew (the level the page chose at the body's scale)."""
    if not mesh:
        return "mesh n/a"
    scale = f" at {mesh['pixels_per_metre']:.0f} pixels a metre" if mesh.get("pixels_per_metre") else ""
    return f"mesh {mesh['mesh']} ({mesh['triangles']} triangles{scale})"


def _header(r: dict) -> str:
    env = r["page"]
    return (f"# The avatar in a web page\n\n"
            f"{r['machine']['cpu']}, {r['machine']['cores']} cores; {env['user_agent']}\n\n"
            f"WebGL: {env['webgl']}; onnxruntime-web {env['backend']}, {env['threads']} thread(s), "
            f"cross-origin isolated: {env['isolated']}; renderer {env['renderer']['precision']} "
            f"({env['renderer']['mode']}), tail in {env.get('tail')}, skinning on the {env.get('skin')}, "
            f"canvas {env.get('display')}, {_mesh_line(env)}\n\nFlags: {r['flags']}\n\n"
            f"Load average while it ran: {r['load_before'][0]:.1f} before, {r['load_after'][0]:.1f} after "
            f"(1 min; 2 cores: above 2 other processes share the CPU)\n\n"
            + (f"The host's speed: a fixed Python loop took {r['host_loop_ms'][0]} ms before and "
               f"{r['host_loop_ms'][1]} ms after (morf.bench.common.host_loop_ms; lower is faster)"
               + (f"; the hypervisor took {100 * r['steal_share']:.1f} % of the CPU time while it ran (steal)"
                  if r.get("steal_share") is not None else "") + "\n\n"
               if r.get("host_loop_ms") else "")
            + f"The browser's CPU time: {env['browser_cpu_s']:.1f} s in all ({r['seconds']:.0f} s wall, the page's "
            f"loading included)\n\n")


def _compare_markdown(r: dict) -> str:
    from morf.bench.common import markdown_table

    c = r["page"]["compare"]
    names = [k for k, v in c.items() if isinstance(v, dict) and "wall" in v]
    rows = [{"": s, **{n: f"{c[n][s]['median']:.1f} / {c[n][s]['best']:.1f}" for n in names}}
            for s in [*STAGES, "show", "total", "wall"] if all(s in c[n] for n in names)]
    cpu = r.get("compare_cpu") or {}
    frames = {n: c[n].get("frames", c["frames"]) for n in names}
    for kind in sorted({k for v in cpu.values() for k in v["by_process"]}):
        if all(cpu.get(n, {}).get("by_process", {}).get(kind, 0) > 0.005 for n in names):
            rows.append({"": f"CPU ms a frame: {kind}", **{n: f"{1000 * cpu[n]['by_process'][kind] / frames[n]:.1f}" for n in names}})
    if cpu and all(n in cpu for n in names):
        rows.append({"": "CPU ms a frame: all", **{n: f"{1000 * cpu[n]['cpu_s'] / frames[n]:.1f}" for n in names}})
    return (_header(r) + f"Compared in turn, {c.get('key', 'crop')}: {' against '.join(names)} at {c['size']} x {c['size']}, "
            f"{c['frames']} frames each (ms a frame, median / best; show: the canvas part of composite; "
            f"wall: each turn's frames' wall time; the browser's CPU time per process kind where played)\n\n"
            + markdown_table(rows, ["", *names]))


def profile_summary(lines: list[str]) -> dict:
    """onnxruntime's profile events (the JSON lines its profiler wrote to the page's console) ->
    runs, kernel ms per run in all, by operator and by node (every node, the costliest first)."""
    import json
    from collections import Counter

    by_op, by_node, runs = Counter(), Counter(), 0
    for line in lines:
        line = line.strip().rstrip(",")
        try:
            e = json.loads(line) if line.startswith("{") else None
        except ValueError:
            continue
        if e and e.get("cat") == "Node" and e.get("name", "").endswith("_kernel_time"):
            by_op[e["args"]["op_name"]] += e["dur"] / 1000
            by_node[f"{e['name'][:-12]} ({e['args']['op_name']})"] += e["dur"] / 1000
        runs += bool(e) and e.get("name") == "model_run"
    n = max(runs, 1)
    return {"runs": runs, "node_ms": sum(by_op.values()) / n,
            "by_op": {k: v / n for k, v in by_op.most_common()}, "by_node": {k: v / n for k, v in by_node.most_common()}}


def _profile_markdown(r: dict) -> str:
    from morf.bench.common import markdown_table

    p = r["profile"]
    rows = [{"": k, "ms a run": v, "share": f"{100 * v / p['node_ms']:.1f} %"} for k, v in [*p["by_op"].items()][:15]]
    nodes = [{"": k, "ms a run": v, "share": f"{100 * v / p['node_ms']:.1f} %"} for k, v in list(p["by_node"].items())[:15]]
    return (_header(r) + f"onnxruntime-web's profiler: {p['runs']} runs of the renderer, {p['node_ms']:.1f} ms of kernel "
            f"time a run (the profiler's own timing; each stage waited for)\n\nBy operator:\n\n"
            + markdown_table(rows, ["", "ms a run", "share"], "{:.2f}") + "\nThe most expensive nodes:\n\n"
            + markdown_table(nodes, ["", "ms a run", "share"], "{:.2f}"))


def _markdown(r: dict) -> str:
    from morf.bench.common import markdown_table

    env = r["page"]
    if "profile" in r:
        return _profile_markdown(r)
    if "compare" in env:
        return _compare_markdown(r)
    rows = [{"stage": s, "ms": env["stages_ms"][s], "share": f"{100 * env['shares'][s]:.0f} %"} for s in STAGES]
    rows.append({"stage": "(of composite: the canvas)", "ms": env["parts_ms"]["show"], "share": ""})
    if env["parts_ms"].get("fill"):
        rows.append({"stage": "(of composite: the colour fill)", "ms": env["parts_ms"]["fill"], "share": ""})
    adaptive = env["adaptive"]
    steps = "; ".join(f"{s['from']} px at {s['fps']:.1f} fps -> {s['to']} px" for s in adaptive["steps"]) or "none"
    win = env["window"]
    shapes = ", ".join(f"{k} ({v} frames)" for k, v in sorted(win.get("shapes", {}).items(), key=lambda kv: -kv[1]))
    where = "the whole frame" if win["margin"] < 0 else f"margin {win['margin']} px"
    cpu = r.get("played_cpu")
    cpu_line = (f"The browser's CPU time while it played: {1000 * cpu['cpu_s'] / r['frames']:.1f} ms a frame "
                f"({cpu['cores']:.2f} cores busy on average; " + ", ".join(
                    f"{k} {1000 * v / r['frames']:.1f}" for k, v in sorted(cpu["by_process"].items(), key=lambda kv: -kv[1])
                    if v > 0) + ")\n\n" if cpu else "")
    if cpu and cpu.get("by_thread"):
        busiest = sorted(cpu["by_thread"].items(), key=lambda kv: -kv[1])[:6]
        cpu_line += ("Its busiest threads (ms a frame; \"renderer DedicatedWorker\": the page's workers, "
                     "onnxruntime-web's thread pool among them, whose idle threads spin; \"gpu-process Thread<N>\": "
                     "SwiftShader's): " + ", ".join(f"{k} {1000 * v / r['frames']:.1f}" for k, v in busiest if v > 0) + "\n\n")
    return (_header(r) +
            f"**{env['size']} x {env['size']}: {env['fps']:.1f} fps end to end** as the page plays "
            f"({env['ms_per_frame']:.1f} ms a frame, {r['frames']} frames; the renderer proxied to a worker: "
            f"{env.get('proxy')}); one frame after another: {env['sequential_fps']:.1f} fps; with each stage waited "
            f"for: {env['staged_fps']:.1f} fps; {_drawn(env.get('mesh_drawn'))}\n\n" + cpu_line +
            f"The person's window ({where}): "
            f"{100 * win['share']:.0f} % of the frame on average; shapes {shapes or 'n/a'}\n\n"
            + markdown_table(rows, ["stage", "ms", "share"], "{:.1f}") +
            f"\nAdaptive size: **{adaptive['size']} x {adaptive['size']}: {adaptive['fps']:.1f} fps** "
            f"(steps: {steps}); settled because: {adaptive.get('why', 'n/a')}; {_drawn(adaptive.get('mesh_drawn'))}\n\n"
            f"Web folder: {r['folder_mb']:.2f} MB ({r['folder']})\n")


def run_web(opts: WebOptions) -> dict:
    """Play the avatar in headless Chromium and write web.json and web.md; returns web.json's content."""
    from morf.bench.common import cpu_ticks, host_loop_ms, machine_info, steal_share, write_results
    from morf.errors import InputError
    from morf.web.browser import missing_browser, run_page
    from morf.web.build import folder_bytes

    why = missing_browser()
    if why:
        raise InputError(why)
    if not 32 <= opts.size <= 4096 or opts.frames < 1 or opts.block < 1:
        raise InputError(f"--size must be 32-4096, --frames and --block positive, got {opts.size}, {opts.frames}, {opts.block}")
    if opts.crop and opts.crop != "off" and not (opts.crop.isdigit() and int(opts.crop) <= 1024):
        raise InputError(f"--crop must be 'off' or a margin of 0-1024 pixels, got {opts.crop!r}")
    if opts.compare and opts.compare != "crop" and not re.fullmatch(r"[a-z]+:[a-z0-9]+,[a-z0-9]+", opts.compare):
        raise InputError(f"--compare must be 'crop' or KEY:A,B (e.g. skin:cpu,gpu), got {opts.compare!r}")
    avatar = Path(opts.avatar)
    if not avatar.is_dir():
        raise InputError(f"avatar folder not found: {avatar}")
    with tempfile.TemporaryDirectory(prefix="morf-bench-web-") as tmp:
        extra = _graph_forms(opts, avatar, Path(tmp))
        folder = _web_folder(avatar, Path(tmp))
        load_before, loop_before = os.getloadavg(), host_loop_ms()
        t0, ticks = time.monotonic(), cpu_ticks()
        page = run_page(folder, _query(opts), extra=extra, isolation=opts.isolation, timeout=opts.timeout)
        seconds, steal = time.monotonic() - t0, steal_share(ticks, cpu_ticks())
        load_after = os.getloadavg()
        time.sleep(1.0)  # the browser's processes gone first
        loop_after = host_loop_ms()
        size = folder_bytes(folder)
    if "error" in page:
        raise InputError(f"the page failed: {page['error'].splitlines()[0]}")
    page.pop("requests", None)
    marks = page.pop("marks", [])
    profile = profile_summary(page.pop("profile")) if "profile" in page else None
    result = {"avatar": str(avatar), "folder": str(folder), "folder_mb": size / 1e6, "frames": opts.frames,
              "flags": _flags(opts), "page": page, "machine": machine_info(), "load_before": load_before,
              "host_loop_ms": [loop_before, loop_after], "steal_share": steal,
              "load_after": load_after, "seconds": round(seconds, 1), "marks": marks,
              "played_cpu": _cpu_between(marks, "played", "played_end"),
              "adaptive_cpu": _cpu_between(marks, "adaptive", "adaptive_end"), "compare_cpu": _cpu_by_setting(marks)}
    if profile is not None:
        result["profile"] = profile
    md = _markdown(result)
    path = write_results(opts.out, "web", result, md)
    print(md)
    print(f"wrote {path}")
    return result
