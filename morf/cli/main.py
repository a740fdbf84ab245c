"""``morf``: entry point. Each sub-command lives in ``morf/cli/<name>.py`` and defines
``add_parser(subparsers)`` and ``run(args) -> int``.

User errors (:class:`morf.errors.MorfError`) print one line and exit non-zero; they never
show a traceback. ``MORF_DEBUG=1`` shows tracebacks for everything.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import sys

from morf import __version__
from morf.errors import MorfError

# Order here is the order in --help: the pipeline, then tools.
COMMANDS = ("run", "batch", "synth", "ingest", "dataset", "fit", "train", "eval", "export", "animate", "play", "motion",
            "web", "serve", "bench", "info", "demo")


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
    except BrokenPipeError:  # `morf info P | head`: the reader has gone; nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error flushing stdout at exit
        return 141
    except OSError as e:  # the environment, not a bug: a read-only folder, a full disk, a vanished file
        if os.environ.get("MORF_DEBUG"):
            raise
        print(f"morf {args.command}: error: {os_error_line(e)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"morf {args.command}: interrupted", file=sys.stderr)
        return 130


def os_error_line(e: OSError) -> str:
    """One line for an OSError: what failed, on which path, and what to do."""
    what = e.strerror or type(e).__name__
    path = f" {e.filename}" if e.filename else ""
    hint = {errno.EACCES: "check the folder's permissions", errno.EPERM: "check the folder's permissions",
            errno.EROFS: "the file system is read-only", errno.ENOSPC: "free some disk space and run it again",
            errno.EDQUOT: "free some disk space and run it again"}.get(e.errno)
    return f"cannot use{path}: {what}" + (f"; {hint}" if hint else "")


if __name__ == "__main__":
    sys.exit(main())
