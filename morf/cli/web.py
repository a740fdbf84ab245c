"""``morf web AVATAR OUT``: an exported avatar folder as a static web folder that plays it live in a
browser; ``morf serve OUT``: that folder on a local server with the cross-origin isolation headers
WASM threads need. A thin wrapper over :mod:`morf.web` (docs/web.md)."""

from __future__ import annotations

import sys


def add_parser(sub):
    p = sub.add_parser("web", help="write a static web folder that plays an exported avatar in a browser")
    p.add_argument("avatar", help="avatar folder written by `morf export`")
    p.add_argument("out", help="the web folder to write (index.html, the player, the avatar, the motions)")
    add_web_options(p, repeat_motion=True)
    s = sub.add_parser("serve", help="serve a web folder locally (with the headers that WASM threads need)")
    s.add_argument("folder", help="a folder written by `morf web` or `morf export --web`")
    s.add_argument("--port", type=int, default=8000, help="TCP port (default 8000; 0: any free port)")
    s.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1; 0.0.0.0 lets other devices in, but browsers "
                        "isolate only https or localhost pages, so they get one thread)")
    s.add_argument("--no-isolation", action="store_true",
                   help="leave out the COOP/COEP headers, as a plain static host does (the page then runs one thread)")
    s.set_defaults(_run=run_serve)
    return p


def add_web_options(p, repeat_motion: bool) -> None:
    """Options of the web folder shared by ``morf web`` and ``morf export --web``."""
    if repeat_motion:
        p.add_argument("--motion", action="append", default=None, metavar="FILE",
                       help="add a motion to the shipped ones (any kind `morf play` reads); repeat for more")
        p.add_argument("--motion-fps", type=float, default=None,
                       help="the frame rate of a motion file that stores none (AIST++ / SMPL .npz); a stored rate wins")
        p.add_argument("--force", action="store_true",
                       help="write into a non-empty OUT, replacing only the files morf web writes")
    p.add_argument("--webgpu", action="store_true",
                   help="also carry onnxruntime-web's WebGPU build (+6.6 MB), used where the browser has WebGPU")
    if repeat_motion:
        p.add_argument("--precision", choices=("auto", "int8", "fp32"), default="auto",
                       help="the renderer the page runs (auto: int8 unless the export measured it under 30 dB "
                            "from fp32; int8 ran 2-3x faster than fp32 in WASM)")


def check_web(out: str, force: bool, motions: list[str] | None, command: str) -> None:
    """What can be refused before any work: the output folder, the cached libraries, the motion files."""
    from morf.io.outputs import claim_output_folder
    from morf.web.libraries import ort_dist
    from morf.web.motions import motion_sources

    claim_output_folder(out, command, force)
    ort_dist()
    motion_sources(motions)


def report(result) -> None:
    print(f"wrote {result.path} ({result.bytes / 1e6:.1f} MB: page, onnxruntime-web {', '.join(result.backends)}, "
          f"{result.precision} renderer ({'tail in the page' if result.renderer == 'tail' else 'whole graph'}), "
          f"motions {', '.join(result.motions)})")
    print(f"open it with: morf serve {result.path}   (or put the folder on any static host: docs/web.md)")


def run(args) -> int:
    from morf.web.build import build_web_folder

    from morf.cli.play import check_rates
    from morf.errors import InputError

    if args.motion_fps is not None and not args.motion:
        raise InputError("--motion-fps goes with --motion FILE")
    args.fps = 30.0
    check_rates(args)
    check_web(args.out, args.force, args.motion, "morf web")
    result = build_web_folder(args.avatar, args.out, motions=args.motion, force=args.force, webgpu=args.webgpu,
                              command="morf web", motion_fps=args.motion_fps, precision=args.precision)
    report(result)
    return 0


def run_serve(args) -> int:
    from pathlib import Path

    from morf.errors import InputError
    from morf.web.server import WebServer

    folder = Path(args.folder)
    if not (folder / "player.json").is_file() or not (folder / "index.html").is_file():
        raise InputError(f"{folder} is not a web folder (no index.html / player.json); write one with "
                         f"morf web AVATAR {folder}")
    if not 0 <= args.port <= 65535:
        raise InputError(f"--port must be from 0 to 65535, got {args.port}")
    server = WebServer(folder, host=args.host, port=args.port, isolation=not args.no_isolation)
    how = "without the isolation headers: one WASM thread" if args.no_isolation else "cross-origin isolated: WASM threads on"
    print(f"serving {folder} at {server.url} ({how}); Ctrl+C stops", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        print("stopped", file=sys.stderr)
    finally:
        server.server_close()
    return 0
