"""``morf bench studio --avatar DIR``: the real studio window playing an avatar, timed.

Opens the studio (a window when DISPLAY is set, else GLFW's null platform with EGL), plays a
motion in the live render panel through the app's own frame loop, and reports the live render's
fps, the UI's frame times and redraw rate, and how the CPU time split between the UI thread, the
live render (its thread, onnxruntime's and software GL's) and the rest. Then it times the same avatar with
``morf bench render``'s measurement (a fresh process) and compares. ``--with-training PROJECT``
trains a copy of PROJECT in the studio's worker meanwhile.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from morf.resources import MOTIONS

DEFAULT_MOTION = MOTIONS / "walk_forward.npz"
LIVE_PANEL = 4  # index of "Live render" in studio.state.PANELS
TARGET_LIVE_RATIO = 0.85  # live panel fps / bench render fps
TARGET_UI_P95_MS = 33.0
TARGET_TYPING_P99_MS = 50.0  # UI frame time while a path is typed into a field
TYPING_CPS = 10.0  # characters a second, as a person types a path
WARMUP_TIMEOUT_S = 120.0  # longest wait, after the warm-up, for the player and the motion


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="morf bench studio", description="The studio window playing an avatar in its "
                                "live render panel, timed, and compared with "
                                "'morf bench render --avatar DIR --out FOLDER' on the same avatar.")
    p.add_argument("--avatar", required=True, help="an exported avatar folder to play")
    p.add_argument("--seconds", type=float, default=20.0, help="timed seconds of playback (after the warm-up)")
    p.add_argument("--warmup", type=float, default=5.0,
                   help="seconds before timing starts (the player opens, the motion loads)")
    p.add_argument("--with-training", metavar="PROJECT", default=None,
                   help="train a copy of this fitted project in the worker meanwhile")
    p.add_argument("--preset", default=None,
                   help="with --with-training: the training preset (default: the one morf train picks, gpu "
                        "with CUDA, else cpu; tiny ends within seconds)")
    p.add_argument("--motion", default=str(DEFAULT_MOTION), help="a .bvh / .npz motion to play")
    p.add_argument("--size", default="1280x800", help="window size WxH")
    p.add_argument("--max-fps", type=float, default=None,
                   help="the studio's cap on UI redraws per second (default: the studio's; 0: redraw continuously)")
    p.add_argument("--live-threads", type=int, default=None,
                   help="onnxruntime threads of the live render (default: the studio's)")
    p.add_argument("--full-frames", action="store_true",
                   help="redraw the whole UI for every live frame (no light frames: studio.ui_cache), for comparison")
    p.add_argument("--serial-live", action="store_true",
                   help="the live render one frame after the other (no overlap of a frame's GL work "
                        "with the last frame's renderer), for comparison")
    p.add_argument("--headless", action="store_true", help="off-screen (EGL) even when DISPLAY is set")
    p.add_argument("--screenshot", metavar="PNG", default=None, help="save the window's last frame")
    p.add_argument("--no-compare", action="store_true", help="skip the render measurement (morf bench render)")
    p.add_argument("--compare-frames", type=int, default=60, help="timed frames of the render measurement (morf bench render)")
    p.add_argument("--rounds", type=int, default=3,
                   help="split the timed seconds into this many rounds with a render measurement (morf bench render) "
                        "before each and after the last, the studio waiting meanwhile; each round is compared "
                        "with the measurements beside it (the host's load drifts between minutes). With "
                        "--with-training the reference is taken before and after the studio only")
    p.add_argument("--out", default=None, help="folder for studio.json and studio.md")
    return p


# ---- CPU time per thread (Linux /proc) -------------------------------------------------------------
def thread_cpu_seconds() -> dict[int, tuple[str, int, float]]:
    """Native thread id -> (name, nice value, CPU seconds) for every thread of this process; empty off Linux."""
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    out = {}
    try:
        tids = os.listdir("/proc/self/task")
    except OSError:
        return out
    for tid in tids:
        try:
            stat = Path(f"/proc/self/task/{tid}/stat").read_text()
        except OSError:
            continue  # the thread ended
        name = stat[stat.index("(") + 1:stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2:].split()
        out[int(tid)] = (name, int(fields[16]), (int(fields[11]) + int(fields[12])) / tick)  # nice, utime + stime
    return out


def cpu_shares(before: dict, after: dict, seconds: float, roles: dict[int, str],
               helper_nice: int | None = None) -> dict[str, float]:
    """Percent of one core per group of threads over ``seconds``.

    Threads in ``roles`` (tid -> name) are their own group. The live render's helpers (its
    onnxruntime pool, numba's threads of the compiled tail and its software GL threads) are
    created by the render thread and inherit its nice value, ``helper_nice``; the other software
    GL threads draw the UI.
    """
    shares: dict[str, float] = {}
    for tid, (name, nice, cpu) in after.items():
        used = cpu - before.get(tid, (name, nice, 0.0))[2]
        gl = name.startswith("llvmpipe")
        if tid in roles:
            group = roles[tid]
        elif helper_nice is not None and nice == helper_nice:
            group = "live render: software GL" if gl else "live render: onnxruntime and numba threads"
        else:
            group = "UI: software GL" if gl else "other threads"
        shares[group] = shares.get(group, 0.0) + 100.0 * used / seconds
    return shares


# ---- the run -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Window:
    """What the studio did in the timed window. All rates per second of wall time."""

    seconds: float
    ui_frames: int
    ui_frame_ms: np.ndarray  # (N,) each UI frame's own time (UI work + its GL rasterization)
    live_frames: int  # frames the live render thread finished
    live_shown: int  # of those, frames the UI put on screen
    ui_light_frames: int  # UI frames that redrew the live image alone (studio.ui_cache)
    live_render_ms: np.ndarray  # (M,) render thread's time per shown frame
    cpu: dict[str, float]  # group -> percent of one core
    train_steps: int | None


def merge_windows(windows: list[Window]) -> Window:
    """The rounds of one run as one window: counts and seconds added, per-frame samples joined,
    CPU shares weighted by each round's seconds."""
    seconds = sum(w.seconds for w in windows)
    cpu: dict[str, float] = {}
    for w in windows:
        for k, v in w.cpu.items():
            cpu[k] = cpu.get(k, 0.0) + v * w.seconds / seconds
    steps = [w.train_steps for w in windows]
    return Window(seconds=seconds, ui_frames=sum(w.ui_frames for w in windows),
                  ui_frame_ms=np.concatenate([w.ui_frame_ms for w in windows]),
                  live_frames=sum(w.live_frames for w in windows), live_shown=sum(w.live_shown for w in windows),
                  ui_light_frames=sum(w.ui_light_frames for w in windows),
                  live_render_ms=np.concatenate([w.live_render_ms for w in windows]), cpu=cpu,
                  train_steps=None if any(t is None for t in steps) else sum(steps))


def _minimal_project(root: Path) -> Path:
    """A one-frame capture project: the live panel needs an open project around it."""
    from morf.capture.project import CaptureProject

    project = CaptureProject.create(root, num_frames=1, width=64, height=64, fps=10.0, source={"kind": "bench"})
    project.save_frame(0, np.full((64, 64, 3), 96, np.uint8))
    project.save_mask(0, np.zeros((64, 64), bool))
    return root


def _prepare_project(tmp: Path, avatar: Path, training_project: str | None) -> Path:
    if training_project:
        root = tmp / Path(training_project).name
        shutil.copytree(training_project, root, symlinks=True)
    else:
        root = _minimal_project(tmp / "bench_project")
    link = root / "avatar"
    if link.is_symlink() or link.is_file():
        link.unlink()
    elif link.is_dir():
        shutil.rmtree(link)
    link.symlink_to(avatar, target_is_directory=True)
    return root


def _playing(app) -> bool:
    """The player opened, rendered a frame, and the motion loaded."""
    live = app.live
    return live is not None and live.ready and live.latest() is not None and app.live_panel.clip is not None


def _step(app) -> int | None:
    progress = app.worker.latest().progress
    return progress.step if progress is not None else None


def _timed_window(app, live, seconds: float, roles: dict[int, str], ui_tid: int, training) -> Window:
    """Run the studio's frame loop for ``seconds`` and say what it did."""
    n0, s0, seq0, step0 = len(app.frame_times), len(app.live_stats), live.latest().seq, _step(app)
    light0 = app.light_frame_count
    cpu0, t0 = thread_cpu_seconds(), time.perf_counter()
    nice = {tid: v[1] for tid, v in cpu0.items()}
    helper_nice = nice.get(live.native_id) if nice.get(live.native_id) != nice.get(ui_tid) else None
    app.run(seconds=seconds)
    t1, cpu1 = time.perf_counter(), thread_cpu_seconds()
    seq1, step1 = live.latest().seq, _step(app)
    stats = app.live_stats[s0:]
    return Window(seconds=t1 - t0, ui_frames=len(app.frame_times) - n0,
                  ui_frame_ms=1e3 * np.asarray(app.frame_times[n0:]), live_frames=seq1 - seq0,
                  live_shown=len(stats), ui_light_frames=app.light_frame_count - light0,
                  live_render_ms=np.asarray([ms for _, ms in stats]),
                  cpu=cpu_shares(cpu0, cpu1, t1 - t0, roles, helper_nice),
                  train_steps=None if not training or step1 is None else step1 - (step0 or 0))


def run_studio(args, avatar: Path, tmp: Path, between=None) -> tuple[list[Window], dict]:
    """Open the studio, play the motion in the live panel, time ``args.seconds`` of it.

    With ``between`` (a callable taking the round number), the seconds are split into
    ``args.rounds`` rounds and ``between(r)`` runs before each round and after the last."""
    from studio.app import StudioApp
    from studio.commands import StartStage
    from studio.sizes import parse_window_size

    project = _prepare_project(tmp, avatar, args.with_training)
    motion = Path(args.motion).resolve()
    headless = args.headless or not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    kw = {} if args.max_fps is None else {"max_fps": args.max_fps}
    kw["live_pipelined"] = not args.serial_live
    if args.live_threads is not None:
        from studio.player import open_live_player

        kw["player_opener"] = lambda d: open_live_player(d, threads=args.live_threads)
    from studio.player import LIVE_RENDER_THREADS

    info: dict = {"window": "headless EGL" if headless else f"X display {os.environ.get('DISPLAY', '')}",
                  "live_threads": args.live_threads or LIVE_RENDER_THREADS}
    with StudioApp(project, size=parse_window_size(args.size), headless=headless, deterministic=False,
                   motion_dir=motion.parent, **kw) as app:
        info["max_fps"], info["idle_fps"] = app.pacer.max_fps, app.pacer.idle_fps
        app.light_frames = not args.full_frames
        info["light_frames"] = app.light_frames
        app.state.select_panel(LIVE_PANEL)
        app.state.motion_file = str(motion)
        app.state.playing = True
        if args.with_training:
            from morf.presets import default_preset  # imports torch: only when training runs beside

            info["train_preset"] = args.preset or default_preset("train")
            app.send(StartStage("train", {"preset": info["train_preset"]}))
        app.run(seconds=args.warmup)
        end = time.perf_counter() + WARMUP_TIMEOUT_S
        while not _playing(app) and time.perf_counter() < end and (app.live is None or not app.live.note):
            app.run(seconds=0.5)
        live = app.live
        if live is None or not live.ready or live.latest() is None:
            why = live.note if live is not None else "no live render"
            raise RuntimeError(f"the live render did not start: {why}")
        if app.live_panel.clip is None:
            raise RuntimeError(f"the motion did not load: {app.live_panel.clip_note}")
        ui_tid = threading.main_thread().native_id
        roles = {ui_tid: "UI thread", live.native_id: "live render thread", app.worker.native_id: "worker thread"}
        rounds = max(1, int(between is not None and args.rounds))
        windows = []
        for r in range(rounds):
            if between is not None:
                between(r)  # the studio's frame loop waits meanwhile: nothing is drawn or rendered
            windows.append(_timed_window(app, live, args.seconds / rounds, roles, ui_tid, args.with_training))
        if between is not None:
            between(rounds)
        info["typing"] = type_a_path(app, str(motion.parent) + "/")
        if args.with_training:  # where training stood at the end (a tiny preset may finish early)
            snap = app.worker.latest()
            info["training"] = {"state": snap.state, "stage": snap.stage, "error": snap.error,
                                "step": snap.progress.step if snap.progress else None,
                                "total": snap.progress.total if snap.progress else None}
        if args.screenshot:
            from morf.io import write_image

            write_image(args.screenshot, app.frame(capture=True))
    return windows, info


def type_a_path(app, path: str, cps: float = TYPING_CPS) -> dict:
    """Type ``path`` into the live panel's motion folder field through the window's own key
    path (studio.input_events) at ``cps`` keys a second while the avatar plays, press Enter
    (the folder is listed on its own thread), and time the UI frames meanwhile."""
    import glfw

    def key(k: int) -> None:
        app.key_event(k, glfw.PRESS)
        app.key_event(k, glfw.RELEASE)

    app.click_item("motion_dir")
    n0, t0 = len(app.frame_times), time.perf_counter()
    app.key_event(glfw.KEY_LEFT_CONTROL, glfw.PRESS)  # select what is there, then type over it
    key(glfw.KEY_A)
    app.key_event(glfw.KEY_LEFT_CONTROL, glfw.RELEASE)
    app.run(seconds=1.0 / cps)
    for ch in path:
        code = glfw.KEY_SLASH if ch == "/" else (getattr(glfw, f"KEY_{ch.upper()}", None) if ch.isalnum() else None)
        if code is not None:
            app.key_event(code, glfw.PRESS)
        app.char_event(ch)
        if code is not None:
            app.key_event(code, glfw.RELEASE)
        app.run(seconds=1.0 / cps)
    key(glfw.KEY_ENTER)
    end = time.perf_counter() + 10.0
    while (app.motions.scanning is not None or app.keys.pending) and time.perf_counter() < end:
        app.run(seconds=0.1)
    app.run(seconds=0.5)
    ms = 1e3 * np.asarray(app.frame_times[n0:])
    listed = app.motions.latest()
    return {"keys": len(path) + 3, "chars_per_s": cps, "seconds": round(time.perf_counter() - t0, 2),
            "frames": int(ms.size), "ui_frame_ms_p50": float(np.percentile(ms, 50)) if ms.size else None,
            "ui_frame_ms_p99": float(np.percentile(ms, 99)) if ms.size else None,
            "ui_frame_ms_max": float(ms.max()) if ms.size else None,
            "typed_in_field": app.state.motion_dir == path,
            "listed": listed is not None and listed.folder == path and listed.error is None}


def summarize(w: Window) -> dict:
    pct = (lambda a, q: float(np.percentile(a, q)) if len(a) else None)
    return {"seconds": round(w.seconds, 2), "live_fps": w.live_frames / w.seconds,
            "live_shown_fps": w.live_shown / w.seconds,
            "live_render_ms_p50": pct(w.live_render_ms, 50), "ui_fps": w.ui_frames / w.seconds,
            "ui_light_fps": w.ui_light_frames / w.seconds,
            "ui_frame_ms_p50": pct(w.ui_frame_ms, 50), "ui_frame_ms_p95": pct(w.ui_frame_ms, 95),
            "ui_frame_ms_max": float(w.ui_frame_ms.max()) if len(w.ui_frame_ms) else None,
            "cpu_percent_of_one_core": {k: round(v, 1) for k, v in sorted(w.cpu.items(), key=lambda kv: -kv[1])},
            "train_steps_per_s": None if w.train_steps is None else w.train_steps / w.seconds}


def report(result: dict) -> str:
    s = result["studio"]
    lines = [f"studio ({result['window']}, UI cap {result['max_fps'] or 'none'} fps, idle {result['idle_fps']} fps), "
             f"{s['seconds']:.0f} s of {Path(result['motion']).name}:",
             f"  live panel: {s['live_fps']:.1f} fps rendered, {s['live_shown_fps']:.1f} fps shown, "
             f"render p50 {s['live_render_ms_p50'] or 0:.0f} ms a frame ({result['live_threads']} onnxruntime threads)",
             f"  UI: {s['ui_fps']:.1f} redraws/s ({s['ui_light_fps']:.1f} of them the live image alone), frame time p50 {s['ui_frame_ms_p50'] or 0:.1f} ms, "
             f"p95 {s['ui_frame_ms_p95'] or 0:.1f} ms, max {s['ui_frame_ms_max'] or 0:.1f} ms",
             "  CPU (% of one core): " + ", ".join(f"{k} {v:.0f}" for k, v in s["cpu_percent_of_one_core"].items())]
    masked = result.get("machine", {}).get("cpu_features", {}).get("cpuid_masked_to")
    if masked:
        lines.append(f"  CPU: {result['machine']['cpu']}")
    if result.get("training"):
        t = result["training"]
        rate = f"{s['train_steps_per_s']:.2f} steps/s; " if s["train_steps_per_s"] is not None else ""
        lines.append(f"  training ({result['preset']} preset): {rate}at the end {t['stage']} {t['state']}, "
                     f"step {t['step']} of {t['total']}" + (f", error: {t['error']}" if t["error"] else ""))
    b = result.get("bench_render")
    if b:
        each = " / ".join(f"{f:.1f}" for f in b["fps_each"])
        lines.append(f"  morf bench render on the same avatar: {b['fps']:.1f} fps end to end (measured {each}, "
                     f"before, between and after the rounds; {b['threads']} onnxruntime threads)")
        per = ", ".join(f"{r['live_fps']:.1f} / {r['bench_fps']:.1f} = {100 * r['ratio']:.0f}%" for r in result["rounds"])
        lines.append(f"  live panel vs bench render, round by round: {per}; median {100 * result['live_vs_bench']:.0f}%")
    t = result.get("typing")
    if t:
        lines.append(f"  typing a path ({t['keys']} keys at {t['chars_per_s']:.0f} a second, then Enter, while it plays): "
                     f"UI frame time p50 {t['ui_frame_ms_p50'] or 0:.1f} ms, p99 {t['ui_frame_ms_p99'] or 0:.1f} ms, "
                     f"max {t['ui_frame_ms_max'] or 0:.1f} ms over {t['frames']} frames; every key in the field: "
                     f"{'yes' if t['typed_in_field'] else 'NO'}; folder listed: {'yes' if t['listed'] else 'NO'}")
    lines.append(f"  targets: live >= {100 * TARGET_LIVE_RATIO:.0f}% of bench render: {result['targets']['live_fps']}; "
                 f"UI p95 < {TARGET_UI_P95_MS:.0f} ms: {result['targets']['ui_p95']}; "
                 f"UI p99 while typing <= {TARGET_TYPING_P99_MS:.0f} ms: {result['targets']['typing_p99']}")
    return "\n".join(lines)


def compare_rounds(windows: list[Window], refs: list[dict]) -> dict:
    """The live panel against ``morf bench render``: each round against the mean of the
    measurements right before and after it (``refs`` has one more entry than ``windows``, or two
    around a single window); the run's ratio is the median round's."""
    fps = [r["fps_end_to_end"] for r in refs]
    rounds = []
    for i, w in enumerate(windows):
        ref = (fps[i] + fps[min(i + 1, len(fps) - 1)]) / 2
        live = w.live_shown / w.seconds  # what the user saw (a pipelined thread may finish one more)
        rounds.append({"live_fps": live, "bench_fps": ref, "ratio": live / ref})
    bench = {"fps": float(np.mean(fps)), "fps_before": fps[0], "fps_after": fps[-1], "fps_each": fps,
             "frame_ms": float(np.mean([r["frame_ms"] for r in refs])),
             "threads": refs[-1].get("threads", 2), "size": refs[-1]["size"]}
    return {"bench_render": bench, "rounds": rounds,
            "live_vs_bench": float(np.median([r["ratio"] for r in rounds]))}


def _bench_render(avatar: Path, frames: int) -> dict:
    """``morf bench render``'s measurement of ``avatar`` at the live panel's size, in a fresh process."""
    from morf.bench.render import measure_in_child
    from studio.player import LIVE_RENDER_SIZE

    return {**measure_in_child(avatar, LIVE_RENDER_SIZE, frames), "size": LIVE_RENDER_SIZE}


def run(args) -> int:
    avatar = Path(args.avatar).resolve()
    if not (avatar / "manifest.json").is_file():
        print(f"morf bench studio: error: not an exported avatar (no manifest.json): {avatar}", file=sys.stderr)
        return 2
    refs: list[dict] = []

    def measure(_round: int = 0) -> None:
        refs.append(_bench_render(avatar, args.compare_frames))

    # with training beside, a reference would share the CPU with it: measure around the studio only
    between = None if (args.no_compare or args.with_training) else measure
    if not args.no_compare and args.with_training:
        measure()
    with tempfile.TemporaryDirectory(prefix="morf-bench-studio-") as tmp:
        windows, info = run_studio(args, avatar, Path(tmp), between)
    if not args.no_compare and args.with_training:
        measure()
    from morf.bench.common import machine_info

    machine = machine_info()
    masked = machine["cpu_features"].get("cpuid_masked_to")  # `morf bench --cpu-as CLASS studio` hands it down
    result: dict = {"benchmark": "studio", "avatar": str(avatar), "motion": str(Path(args.motion).resolve()),
                    "size": args.size, "with_training": args.with_training,
                    "preset": info.pop("train_preset", None),  # before **info: recorded once
                    **info, "studio": summarize(merge_windows(windows)), "machine": machine,
                    "command": "morf bench " + (f"--cpu-as {masked} " if masked else "") + "studio "
                               + " ".join(sys.argv[1:])}
    if refs:
        result.update(compare_rounds(windows, refs))
    ratio, p95 = result.get("live_vs_bench"), result["studio"]["ui_frame_ms_p95"]
    p99 = (result.get("typing") or {}).get("ui_frame_ms_p99")
    result["targets"] = {"live_fps": "n/a" if ratio is None else ("met" if ratio >= TARGET_LIVE_RATIO else "missed"),
                         "ui_p95": "n/a" if p95 is None else ("met" if p95 < TARGET_UI_P95_MS else "missed"),
                         "typing_p99": "n/a" if p99 is None else ("met" if p99 <= TARGET_TYPING_P99_MS else "missed")}
    text = report(result)
    print(text)
    if args.out:
        from morf.bench.common import write_results

        path = write_results(args.out, "studio", result, "# Studio live render\n\n```\n" + text + "\n```\n")
        print(f"wrote {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    return run(build_parser().parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
