"""``morf serve OUT``: a web folder written by ``morf web`` (or ``morf export --web``) on a local
server, with the cross-origin isolation headers WASM threads need. A thin wrapper over
:class:`morf.web.server.WebServer` (docs/web.md)."""

from __future__ import annotations

import sys


def add_parser(sub):
    s = sub.add_parser("serve", help="serve a web folder locally (with the headers that WASM threads need)")
    s.add_argument("folder", help="a folder written by `morf web` or `morf export --web`")
    s.add_argument("--port", type=int, default=8000, help="TCP port (default 8000; 0: any free port)")
    s.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1; 0.0.0.0 lets other devices in, but browsers "
                        "isolate only https or localhost pages, so they get one thread)")
    s.add_argument("--no-isolation", action="store_true",
                   help="leave out the COOP/COEP headers, as a plain static host does (the page then runs one thread)")
    return s


def run(args) -> int:
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
