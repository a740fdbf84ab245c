"""``morf batch CAPTURES --until STAGE``: many captures through ``morf run`` at once, on Ray.

CAPTURES is a folder or a text file. In a folder every sub-folder is a capture project, and every
video (:data:`VIDEO_SUFFIXES`) is ingested into the project of its name beside it (``alice.mp4`` ->
``alice/``); hidden entries and other files are left alone. A text file names one project folder
or video per line, relative to the file's folder; blank lines and lines starting with ``#`` are
skipped.

Each capture runs the chain of ``morf run`` (ingest, fit, train, export; finished stages skipped,
stopped ones resumed) as one Ray task that holds ``--cpus-per-task`` cores and, with ``--preset
gpu``, one GPU. A capture that fails is reported with its error and the others go on; a task whose
worker dies is started again (``--retries``) and continues where it stopped, and running the same
command again continues them all. Every capture's outcome goes to ``batch.json`` (in the captures
folder, or beside the list; ``--out FILE`` puts it elsewhere), rewritten atomically as each capture
ends. The exit status is 1 when any capture failed.
"""

from __future__ import annotations

import shlex
import time
from dataclasses import dataclass
from pathlib import Path

from morf.presets import PRESETS

STAGES = ("ingest", "fit", "train", "export")  # as morf run
VIDEO_SUFFIXES = (".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm")
LOG_LINES = 30  # the last lines of a capture's output kept in batch.json


def add_parser(sub):
    from morf.scale.ray_runtime import add_arguments as ray_arguments

    p = sub.add_parser("batch", help="many captures through 'morf run' at once, on Ray (a failed one does not stop "
                                     "the others; running it again continues)",
                       description="Run ingest, fit, train and export ('morf run') on every capture of a folder or "
                                   "list, in parallel where resources allow, on a local Ray or a cluster.")
    p.add_argument("captures", help="a folder of capture projects (and videos to ingest), or a text file naming one "
                                    "project folder or video per line ('#' starts a comment line)")
    p.add_argument("--until", choices=STAGES, default="export", help="stop each capture after this stage "
                                                                     "(default export)")
    p.add_argument("--preset", choices=(*PRESETS["train"], "auto"), default=None,
                   help="training size for every capture (as 'morf run --preset'; gpu also reserves one GPU a "
                        "capture); default: what 'morf run' picks for each")
    p.add_argument("--holdout", type=int, default=None, metavar="K", help="as 'morf run --holdout'")
    p.add_argument("--out", type=Path, default=None, metavar="FILE",
                   help="where the outcome goes (default: batch.json in the captures folder, or beside the list)")
    p.add_argument("--retries", type=int, default=2, metavar="N",
                   help="start a capture again up to N times when its worker dies (default 2)")
    ray_arguments(p, "cores each capture holds (default 1; torch runs on as many threads)")
    return p


@dataclass(frozen=True)
class Capture:
    """One capture of a batch.

    Fields:
        name: how messages and batch.json call it (its folder name, or its path where two share one);
        project: the project folder (absolute); video: the video to ingest into it, or None.
    """

    name: str
    project: Path
    video: Path | None = None


def find_captures(source: Path) -> list[Capture]:
    """The captures a folder or a list names (see the module's docstring), in name order for a
    folder and line order for a list."""
    from morf.errors import InputError

    if not source.exists():
        raise InputError(f"captures not found: {source}")
    if source.is_dir():
        entries = sorted(p for p in source.iterdir() if not p.name.startswith(".")
                         and (p.is_dir() or p.suffix.lower() in VIDEO_SUFFIXES))
        where = f"folder {source}"
    else:
        try:
            lines = source.read_text().splitlines()
        except (OSError, UnicodeDecodeError) as e:
            raise InputError(f"cannot read the capture list {source}: {e}") from None
        entries = [source.parent / line.strip() for line in lines if line.strip() and not line.strip().startswith("#")]
        missing = [str(p) for p in entries if not p.exists()]
        if missing:
            raise InputError(f"{source} names {len(missing)} path(s) that do not exist: {', '.join(missing[:3])}")
        where = f"list {source}"
    found: dict[Path, Path | None] = {}  # project -> video
    for p in entries:
        p = p.resolve()
        project, video = (p.with_suffix(""), p) if p.is_file() else (p, None)
        if project in found and (video is None) == (found[project] is None):  # a folder and its video are one
            raise InputError(f"the {where} names {project} twice" + (" (two videos)" if video else ""))
        found[project] = video or found.get(project)
    if not found:
        raise InputError(f"no captures in the {where} (capture project folders or videos)")
    names = [p.name for p in found]
    return [Capture(p.name if names.count(p.name) == 1 else str(p), p, v) for p, v in found.items()]


def run_capture(project: str, video: str | None, until: str, preset: str | None, holdout: int | None) -> dict:
    """On a Ray worker: ``morf run`` on one capture, its output kept; {"exit_code", "error", "log",
    "seconds"} with error the line that says why it failed (None when it did not), log its last
    lines and seconds the time it ran (its last start, when its worker died before)."""
    import contextlib
    import io

    from morf.cli.main import main

    argv = ["run", project, "--until", until]
    for flag, value in (("--video", video), ("--preset", preset), ("--holdout", holdout)):
        if value is not None:
            argv += [flag, str(value)]
    buf = io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        rc = main(argv)
    lines = [line for line in buf.getvalue().splitlines() if line.strip()]
    return {"exit_code": rc, "error": _why(lines) if rc else None, "log": lines[-LOG_LINES:],
            "seconds": round(time.perf_counter() - t0, 1)}


def _why(lines: list[str]) -> str:
    """The first error a command printed, else its last line."""
    errors = [line for line in lines if ": error: " in line]
    return errors[0] if errors else (lines[-1] if lines else "failed without a message")


def run(args) -> int:
    from morf.errors import InputError
    from morf.scale.ray_runtime import describe, options_from_args, resources_for
    from morf.scale.tasks import Task, run_tasks

    options = options_from_args(args)
    if args.holdout is not None and args.holdout < 2:
        raise InputError(f"--holdout must be at least 2 (every K-th frame kept out), got {args.holdout}")
    if args.retries < 0:
        raise InputError(f"--retries must be 0 or more, got {args.retries}")
    source = Path(args.captures)
    captures = find_captures(source)
    out = args.out or (source / "batch.json" if source.is_dir() else source.parent / "batch.json")
    resources = resources_for(args.preset, args.cpus_per_task)
    tasks = [Task(f"batch:{c.name}", run_capture, (str(c.project), str(c.video) if c.video else None, args.until,
                                                   args.preset, args.holdout), resources, args.retries)
             for c in captures]
    rows = {c.name: {"name": c.name, "project": str(c.project), "video": str(c.video) if c.video else None,
                     "status": "waiting", "exit_code": None, "error": None, "seconds": None, "node": None,
                     "log": []}
            for c in captures}
    head = {"source": str(source.resolve()), "until": args.until, "preset": args.preset, "holdout": args.holdout,
            "cpus_per_task": args.cpus_per_task, "gpus_per_task": resources.num_gpus,
            "started": time.strftime("%Y-%m-%d %H:%M:%S")}
    _write(out, head, rows)
    head["ray"] = describe(options)
    ray = head["ray"]
    where = "in this process, one after another" if options.in_process else (
        f"on Ray ({ray['address']}: {ray['nodes']} node(s), {ray['cpus']:g} CPUs, {ray['gpus']:g} GPUs)")
    print(f"morf batch: {len(captures)} capture{'s' if len(captures) > 1 else ''} until {args.until} {where}; "
          f"{args.cpus_per_task} core(s) each")

    def done(o):
        row = rows[o.name.removeprefix("batch:")]
        value = o.value or {}
        failed = not o.ok or value.get("exit_code") != 0
        row.update(status="failed" if failed else "done", exit_code=value.get("exit_code"),
                   seconds=value.get("seconds", round(o.seconds, 1)), error=o.error or value.get("error"),
                   node=o.node, log=value.get("log", []))
        finished = sum(r["status"] != "waiting" for r in rows.values())
        print(f"[{finished}/{len(rows)}] {row['name']}: " + (f"failed: {row['error']}" if failed
                                                               else f"done in {row['seconds']:.0f} s"))
        _write(out, head, rows)

    run_tasks(tasks, options, args.workers, done)
    _write(out, {**head, "finished": time.strftime("%Y-%m-%d %H:%M:%S")}, rows)
    print(_table(list(rows.values())))
    failed = [r for r in rows.values() if r["status"] == "failed"]
    print(f"morf batch: {len(rows) - len(failed)} done, {len(failed)} failed; outcome in {out}"
          + (f"; fix them and continue with: morf batch {shlex.quote(str(source))}" if failed else ""))
    return 1 if failed else 0


def _write(path: Path, head: dict, rows: dict) -> None:
    from morf.io import atomic_write_json

    listed = list(rows.values())
    atomic_write_json(path, {**head, "done": sum(r["status"] == "done" for r in listed),
                             "failed": sum(r["status"] == "failed" for r in listed), "captures": listed})


def _table(rows: list[dict]) -> str:
    """The summary: one line per capture (name, status, seconds, node, error)."""
    cells = [("capture", "status", "seconds", "node", "error")]
    cells += [(r["name"], r["status"], "" if r["seconds"] is None else f"{r['seconds']:.0f}", r["node"] or "",
               r["error"] or "") for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(4)]
    return "\n".join(("  ".join(c[i].ljust(widths[i]) for i in range(4)) + "  " + c[4]).rstrip() for c in cells)
