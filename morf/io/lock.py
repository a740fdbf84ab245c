"""One writer at a time: a lock per project stage, held by one process.

``PROJECT/.locks/<stage>.lock`` is ``flock``ed (exclusive, non-blocking) while a command writes
that stage (``fit``, ``export``, ``eval``, ``run-<name>`` for one training run), and it holds JSON
naming the holder (pid, host, command, start time), as Cargo does for its package cache. A second
writer is refused with one line naming the holder. The kernel drops the lock when its process
dies, however it dies (``kill -9`` included), so a lock left by a killed process is free again and
the next command takes it over; the file itself is never deleted (deleting a lock file races with
a process that has just opened it).

Within one process the lock is re-entrant (``morf run`` takes ``fit`` and then calls the fit, which
takes it too; the studio's worker thread trains while its UI thread reads), counted per path.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shlex
import socket
import sys
import threading
import time
from pathlib import Path
from typing import Iterator

from morf.errors import ProjectError

LOCK_DIR = ".locks"

_held: dict[Path, list] = {}  # path -> [fd, count] for locks this process holds
_guard = threading.Lock()


def lock_path(project_root: str | os.PathLike, stage: str) -> Path:
    """The lock file of ``stage`` in the project (stage: fit, export, eval, run-<name>, ...)."""
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in stage)
    return Path(project_root) / LOCK_DIR / f"{safe}.lock"


def current_command() -> str:
    """The command line of this process as a user would type it (``morf train P``)."""
    argv = list(sys.argv)
    if argv and Path(argv[0]).name in ("morf", "main.py", "__main__.py", "-m", "-c"):
        argv[0] = "morf"
    return " ".join(shlex.quote(a) for a in argv) or "python"


def read_holder(path: Path) -> dict:
    """What a lock file says of its holder ({} when it says nothing readable)."""
    try:
        d = json.loads(path.read_text())
        return d if isinstance(d, dict) else {}
    except (OSError, ValueError):
        return {}


def _stage_words(stage: str) -> str:
    if stage.startswith("run-"):
        return f"the training run {stage[4:]!r}"
    return {"fit": "the body fit", "export": "the avatar export", "eval": "the evaluation"}.get(stage, f"the {stage} stage")


def _refusal(project_root, stage: str, holder: dict) -> ProjectError:
    since = holder.get("started")
    when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(since)) if isinstance(since, (int, float)) else "?"
    host = holder.get("host")
    where = f" on {host}" if host and host != socket.gethostname() else ""
    return ProjectError(f"{project_root}: {_stage_words(stage)} is being written by another morf process (pid {holder.get('pid', '?')}"
                        f"{where}, `{holder.get('command', '?')}`, since {when}); wait for it to finish or stop it")


def acquire(project_root: str | os.PathLike, stage: str, command: str | None = None) -> Path:
    """Take the lock of ``stage`` (re-entrant within this process); a ProjectError when another
    process holds it. Returns the lock file's path, for :func:`release`."""
    path = lock_path(project_root, stage)
    with _guard:
        if path in _held:
            _held[path][1] += 1
            return path
        try:
            path.parent.mkdir(exist_ok=True)
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise ProjectError(f"cannot write {path}: {e.strerror}; this command writes into the project, so "
                               f"{project_root} must be writable") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise _refusal(project_root, stage, read_holder(path)) from None
        except BaseException:
            os.close(fd)
            raise
        holder = {"pid": os.getpid(), "host": socket.gethostname(), "command": command or current_command(),
                  "started": time.time()}
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(holder) + "\n").encode(), 0)
        _held[path] = [fd, 1]
        return path


def release(path: Path) -> None:
    """Give back a lock taken with :func:`acquire` (the last release of this process unlocks it)."""
    with _guard:
        entry = _held.get(path)
        if entry is None:
            return
        entry[1] -= 1
        if entry[1] > 0:
            return
        del _held[path]
        fd = entry[0]
        try:
            os.ftruncate(fd, 0)  # no holder named once it is free
        except OSError:
            pass
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


@contextlib.contextmanager
def project_lock(project_root: str | os.PathLike, stage: str, command: str | None = None) -> Iterator[Path]:
    """Hold the lock of ``stage`` in the project for the ``with`` block (see the module docstring)."""
    path = acquire(project_root, stage, command)
    try:
        yield path
    finally:
        release(path)


def holder_of(project_root: str | os.PathLike, stage: str) -> dict | None:
    """The holder of ``stage``'s lock when another process holds it now; None when it is free."""
    path = lock_path(project_root, stage)
    if not path.is_file():
        return None
    with _guard:
        if path in _held:
            return None
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return read_holder(path) or {"pid": "?"}
    finally:
        os.close(fd)  # closing drops a shared lock we got
    return None


def held_locks(project_root: str | os.PathLike) -> list[tuple[str, dict]]:
    """(stage, holder) of every lock of the project another process holds now."""
    folder = Path(project_root) / LOCK_DIR
    if not folder.is_dir():
        return []
    out = []
    for path in sorted(folder.glob("*.lock")):
        holder = holder_of(project_root, path.stem)
        if holder is not None:
            out.append((path.stem, holder))
    return out
