"""``morf web AVATAR OUT``: an exported avatar folder as a static web folder that plays it live in a
browser (``morf serve OUT`` serves it: :mod:`morf.cli.serve`). A thin wrapper over :mod:`morf.web`
(docs/web.md)."""

from __future__ import annotations

from morf.cli.options import add_force_option, add_motion_fps_option, check_frame_rate


def add_parser(sub):
    p = sub.add_parser("web", help="write a static web folder that plays an exported avatar in a browser")
    p.add_argument("avatar", nargs="?", help="avatar folder written by `morf export`")
    p.add_argument("out", nargs="?", help="the web folder to write (index.html, the player, the avatar, the motions)")
    p.add_argument("--fetch-libs", action="store_true",
                   help="first fetch the pinned onnxruntime-web from the npm registry into the user's cache "
                        "(~/.cache/morf/web-libs; once per machine); alone, only that")
    p.add_argument("--motion", action="append", default=None, metavar="FILE",
                   help="add a motion to the shipped ones (any kind `morf play` reads); repeat for more")
    add_motion_fps_option(p, "the frame rate of a motion file that stores none (AIST++ / SMPL .npz); a stored rate "
                             "wins")
    add_force_option(p, "write into a non-empty OUT, replacing only the files morf web writes")
    p.add_argument("--webgpu", action="store_true",
                   help="also carry onnxruntime-web's WebGPU build (+6.6 MB), used where the browser has WebGPU")
    p.add_argument("--precision", choices=("auto", "int8", "fp32"), default="auto",
                   help="the renderer the page runs (auto: int8 unless the export measured it under 30 dB "
                        "from fp32; int8 ran 2-3x faster than fp32 in WASM)")
    return p


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

    from morf.errors import InputError

    if args.fetch_libs:
        from morf.web.libraries import fetch_libraries

        if fetch_libraries() != 0:
            raise InputError("could not fetch onnxruntime-web from the npm registry (the reason is above); "
                             "set MORF_WEB_LIBS to a folder holding onnxruntime-web/ instead")
        if args.avatar is None and args.out is None:
            return 0
    if args.avatar is None or args.out is None:
        raise InputError("morf web needs AVATAR and OUT (or --fetch-libs alone)")
    if args.motion_fps is not None and not args.motion:
        raise InputError("--motion-fps goes with --motion FILE")
    check_frame_rate("--motion-fps", args.motion_fps)
    check_web(args.out, args.force, args.motion, "morf web")
    result = build_web_folder(args.avatar, args.out, motions=args.motion, force=args.force, webgpu=args.webgpu,
                              command="morf web", motion_fps=args.motion_fps, precision=args.precision)
    report(result)
    return 0
