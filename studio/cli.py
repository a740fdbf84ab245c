"""``morf-studio``'s command line: its options, and what they do to a :class:`studio.app.StudioApp`.

The app's class is handed in (:func:`run_cli`), so this file needs nothing of the window's.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

from morf.errors import InputError, MorfError
from studio.commands import StartStage
from studio.pacing import IDLE_FPS, MAX_FPS
from studio.pipeline_run import STAGES as PIPELINE_STAGES, PipelineRequest
from studio.sizes import parse_window_size


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="morf-studio", description="MoRF Studio: review captures, train and play avatars.")
    p.add_argument("project", nargs="?", help="capture project folder to open (with --video: the new project's folder)")
    p.add_argument("--video", metavar="FILE", help="make the project from this video (or folder of frames) in the studio: "
                                                   "ingest, fit, train and export, as 'morf run PROJECT --video FILE' does")
    p.add_argument("--until", choices=PIPELINE_STAGES, default="export",
                   help="with --video: stop after this stage (default export)")
    p.add_argument("--size", default="1280x800", help="window size WxH (default 1280x800)")
    p.add_argument("--headless-frames", type=int, metavar="N",
                   help="render N frames off-screen (no display needed) and exit")
    p.add_argument("--screenshot", metavar="PNG", help="with --headless-frames: save the last frame")
    p.add_argument("--frame-times", action="store_true", help="print p50 / p95 UI frame times at exit")
    p.add_argument("--stage", metavar="NAME", help="start a stage at launch (fit, train, export; cpu-load for a UI load test)")
    p.add_argument("--preset", metavar="NAME", help="with --stage: the stage's config preset (e.g. train: tiny, cpu, "
                                                    "gpu; default: the one 'morf fit PROJECT' / 'morf train PROJECT' picks); "
                                                    "with --video: the training size, as for 'morf run PROJECT --video FILE'")
    p.add_argument("--motion", metavar="FILE", help="a .bvh / .npz motion for the live render (5) to play")
    p.add_argument("--panel", type=int, choices=range(1, 6), metavar="1-5", help="panel to show first")
    p.add_argument("--frame", type=int, default=0, metavar="I", help="frame to show first")
    p.add_argument("--help-overlay", action="store_true", help="open the key help at start")
    p.add_argument("--play", action="store_true", help="start playing the frames (as Space does)")
    p.add_argument("--max-fps", type=float, default=MAX_FPS,
                   help=f"redraw at most this often (default {MAX_FPS:g}; 0: redraw continuously)")
    p.add_argument("--idle-fps", type=float, default=IDLE_FPS,
                   help=f"redraw this often when nothing changes (default {IDLE_FPS:g})")
    return p


def frame_time_report(times_s: list[float], skip: int = 10) -> str:
    """'UI frame time over N frames: p50 x ms, p95 y ms, max z ms' (first ``skip`` frames left out)."""
    t = np.asarray(times_s[skip:] if len(times_s) > skip else times_s) * 1000.0
    if t.size == 0:
        return "UI frame time: no frames"
    return (f"UI frame time over {t.size} frames: p50 {np.percentile(t, 50):.1f} ms, "
            f"p95 {np.percentile(t, 95):.1f} ms, max {t.max():.1f} ms")


def live_render_report(stats: list[tuple[float, float]]) -> str:
    """'live render: N frames, median x fps, median y ms a frame' from (fps, render_ms) samples."""
    fps = np.asarray([f for f, _ in stats if f], np.float64)
    ms = np.asarray([m for _, m in stats], np.float64)
    if not len(ms):
        return "live render: no frames"
    rate = f"median {np.median(fps):.1f} fps, " if len(fps) else ""
    return f"live render: {len(ms)} frames, {rate}median {np.median(ms):.1f} ms a frame on its own thread"


def run_cli(args: argparse.Namespace, app_class) -> int:
    """Open the studio (``app_class``: :class:`studio.app.StudioApp`) as ``args`` say; the exit status."""
    size = parse_window_size(args.size)
    if args.screenshot and not args.headless_frames:
        raise MorfError("--screenshot needs --headless-frames N")
    headless = bool(args.headless_frames) or not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if headless and not args.headless_frames:
        raise MorfError("no display found (DISPLAY / WAYLAND_DISPLAY unset); use "
                        "'morf-studio PROJECT --headless-frames N --screenshot PNG'")
    if args.video and not args.project:
        raise InputError("--video makes a new project: give its folder first, 'morf-studio NEWFOLDER --video FILE'")
    if args.video and args.stage:
        raise InputError("--video runs every stage from ingest on; --stage runs one on an existing project: give one")
    if args.video and args.preset:
        from morf.presets import PRESETS

        sizes = (*PRESETS["train"], "auto")
        if args.preset not in sizes:
            raise InputError(f"with --video, --preset is the training size: one of {', '.join(sizes)} (got {args.preset})")
    opened = None if args.video else args.project
    with app_class(opened, size=size, headless=headless, max_fps=args.max_fps, idle_fps=args.idle_fps) as app:
        if args.video:
            app.start_pipeline(PipelineRequest(args.project, args.video, args.until, args.preset))
        if args.panel:
            app.state.select_panel(args.panel - 1)
        if app.view is not None:
            app.state.frame = max(0, min(args.frame, app.view.num_frames - 1))
        app.state.show_help = args.help_overlay
        app.state.playing = args.play
        if args.motion:
            app.state.motion_file = str(Path(args.motion).resolve())
        if args.stage:
            app.send(StartStage(args.stage, {"preset": args.preset} if args.preset else {}))
        if args.headless_frames:
            if args.screenshot and not (args.stage or args.video):
                app.settle()  # every image decoded and uploaded: a complete picture
            shot = app.run(args.headless_frames, pace_hz=60.0, capture_last=bool(args.screenshot))
            if args.screenshot and shot is not None:
                from morf.io import write_image

                write_image(args.screenshot, shot)
                print(f"screenshot: {args.screenshot}")
        else:
            app.run()
        if app.worker.latest().error:
            print(f"morf-studio: last error: {app.worker.latest().error}", file=sys.stderr)
        if args.frame_times:
            print(frame_time_report(app.frame_times))
            if app.live_stats:
                print(live_render_report(app.live_stats))
    return 0
