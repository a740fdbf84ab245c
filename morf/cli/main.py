"""``morf``: entry point. Each sub-command lives in ``morf/cli/<name>.py`` and defines
``add_parser(subparsers)`` and ``run(args) -> int``.

User errors (:class:`morf.errors.MorfError`) print one line and exit non-zero; they never
show a traceback. ``MORF_DEBUG=1`` shows tracebacks for everything.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from morf import __version__
from morf.errors import MorfError

# Order here is the order in --help: the pipeline, then tools.
COMMANDS = ("run", "batch", "synth", "ingest", "dataset", "fit", "train", "eval", "export", "animate", "play", "motion",
            "bench", "info", "demo")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="morf", description="MoRF Studio: neural full-body avatars from a monocular video.")
    parser.add_argument("--version", action="version", version=f"morf {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"morf.cli.{name}")
        except ModuleNotFoundError as e:
            if e.name == f"morf.cli.{name}":
                continue  # command not part of this build
            raise
        p = module.add_parser(sub)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 1
    try:
        return int(args._run(args) or 0)
    except MorfError as e:
        if os.environ.get("MORF_DEBUG"):
            raise
        print(f"morf {args.command}: error: {e}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt:
        print(f"morf {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
