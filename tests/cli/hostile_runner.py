"""Runs one hostile-input case as a user would: a fresh folder, the real ``morf`` command, and a
record of every file under that folder before and after.

The command runs either in a fresh Python process (:func:`run_command`, as typed in a shell) or
in this one through the same entry point, ``morf.cli.main.main(argv)`` (:func:`run_in_process`),
with what a fresh process would differ in put back: its working directory, its environment, its
stdout and stderr taken at the file descriptors (so C libraries' output is caught too), Python's
default warning filters with every warning written to stderr as a fresh process would, an
uncaught exception printed as a traceback with exit code 1, and ``SystemExit`` turned into the
exit code. That saves the seconds of interpreter start and imports per case. Filters a library
module sets when it is first imported are not replayed (this process imported it long before):
the in-process run may report a warning such a filter would hide, never miss one a fresh process
shows.

A case's folder holds everything the command is given (a private copy of the capture project as
``P``, or of its avatar as ``A``, the user's other folders and files), and it is the working
directory, so the command line reads as typed. The snapshot is path -> (kind, size, sha256,
mtime_ns); lock files under ``.locks/`` are left out (they are the command's own bookkeeping and
say who holds the project, so every writer rewrites them).
"""

from __future__ import annotations

import contextlib
import io
import os
import resource
import shlex
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
import traceback
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from morf.export.avatar_folder import sha256_of

LOCK_DIR = ".locks"
COMMAND_TIMEOUT_S = 240  # far above any case; a command that hangs fails its case, not the suite


@dataclass(frozen=True)
class Fixture:
    """What the session built once, shared read-only by every case.

    Fields:
        project: a tiny synthetic capture, fitted, trained (run ``morf-tiny``) and exported.
        bvh: a 104-joint BVH written by ``morf motion export`` (the good BVH every BVH case edits).
        bomb: an .npz of about 1.5 MB whose rotvecs expand to 320 MiB.
        seconds: what building it took, per step.
    """

    project: Path
    bvh: Path
    bomb: Path
    seconds: dict


@dataclass
class Outcome:
    """What one case did."""

    argv: list[str]
    rc: int | None = None
    stdout: str = ""
    stderr: str = ""
    before: dict = field(default_factory=dict)
    after: dict = field(default_factory=dict)
    seconds: float = 0.0
    cpu_seconds: float = 0.0  # user + system time of the command and its children
    holder_pid: int | None = None
    skipped: str | None = None
    folder: Path | None = None
    problems: list[str] | None = None  # what the test found wrong (None: not checked yet)


def morf_command() -> list[str]:
    """The CLI as the suite runs it: this interpreter, ``-m morf.cli.main``."""
    return [sys.executable, "-m", "morf.cli.main"]


def command_env() -> dict:
    env = dict(os.environ)
    env.pop("MORF_DEBUG", None)  # tracebacks must not be switched on
    env["MORF_QUIET"] = "1"
    env["OMP_NUM_THREADS"] = "1"  # two cases run at once on two cores
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[2]) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def snapshot(root: Path) -> dict[str, tuple]:
    """Every entry under ``root`` (relative path -> what it is), symlinks not followed, lock files
    left out. Files: ("file", size, sha256, mtime_ns); folders: ("dir",); links: ("link", target)."""
    out: dict[str, tuple] = {}
    if not root.exists():
        return out
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        here = Path(dirpath)
        if LOCK_DIR in dirnames:
            dirnames.remove(LOCK_DIR)
        for name in dirnames + filenames:
            p = here / name
            rel = p.relative_to(root).as_posix()
            try:
                st = p.lstat()
            except FileNotFoundError:
                continue
            if stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(p))
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = ("dir",)
            elif stat.S_ISREG(st.st_mode):
                try:
                    out[rel] = ("file", st.st_size, sha256_of(p), st.st_mtime_ns)
                except PermissionError:
                    out[rel] = ("file", st.st_size, "unreadable", st.st_mtime_ns)
            else:
                out[rel] = ("other", stat.S_IFMT(st.st_mode))
    return out


def changes(before: dict, after: dict) -> dict[str, str]:
    """path -> "added" | "removed" | "changed"."""
    out = {}
    for k in before.keys() | after.keys():
        if k not in after:
            out[k] = "removed"
        elif k not in before:
            out[k] = "added"
        elif before[k] != after[k]:
            out[k] = "changed"
    return dict(sorted(out.items()))


def run_command(argv: list[str], cwd: Path) -> tuple[int | None, str, str, float]:
    """(exit code or None on timeout, stdout, stderr, CPU seconds) of ``argv`` run in ``cwd``."""
    p = subprocess.Popen(argv, cwd=cwd, env=command_env(), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    killed = threading.Event()

    def kill() -> None:
        killed.set()
        p.kill()

    timer = threading.Timer(COMMAND_TIMEOUT_S, kill)
    timer.start()
    try:
        with ThreadPoolExecutor(2) as pool:
            stdout, stderr = pool.submit(p.stdout.read), pool.submit(p.stderr.read)
            _, status, usage = os.wait4(p.pid, 0)
            text = [f.result().decode(errors="replace") for f in (stdout, stderr)]
    finally:
        timer.cancel()
        p.stdout.close()
        p.stderr.close()
    p.returncode = os.waitstatus_to_exitcode(status)  # reaped here, so Popen must not wait again
    rc = None if killed.is_set() else p.returncode
    if killed.is_set():
        text[1] += f"\n[killed after {COMMAND_TIMEOUT_S} s]"
    return rc, text[0], text[1], usage.ru_utime + usage.ru_stime


# Python's warning filters in a fresh process without -W or -X dev (``warnings.filters`` at start-up):
# these categories are not shown; everything else is shown once per place.
_HIDDEN_BY_DEFAULT = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


@contextlib.contextmanager
def _captured_output():
    """File descriptors 1 and 2 into two files, with ``sys.stdout`` / ``sys.stderr`` writing
    through to them, as a child's pipes take both Python's and C libraries' output. Yields
    ``read() -> (stdout, stderr)``, valid once the block has ended."""
    files = [tempfile.TemporaryFile(), tempfile.TemporaryFile()]
    streams = sys.stdout, sys.stderr
    for stream in streams:
        stream.flush()
    saved = [os.dup(1), os.dup(2)]
    texts: list[str] = []
    try:
        os.dup2(files[0].fileno(), 1)
        os.dup2(files[1].fileno(), 2)
        sys.stdout, sys.stderr = (io.TextIOWrapper(open(os.dup(fd), "wb", buffering=0), encoding="utf-8",
                                                   errors="replace", write_through=True) for fd in (1, 2))
        yield lambda: (texts[0], texts[1])
    finally:
        for stream in (sys.stdout, sys.stderr):
            stream.close()
        sys.stdout, sys.stderr = streams
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved:
            os.close(fd)
        for f in files:
            f.seek(0)
            texts.append(f.read().decode(errors="replace"))
            f.close()


@contextlib.contextmanager
def _as_a_fresh_process(cwd: Path):
    """The working directory and the environment of :func:`run_command`'s child, restored after.
    Variables are set and removed one by one: a thread starting a child meanwhile never sees an
    empty environment."""
    before, here = dict(os.environ), os.getcwd()
    _set_environment(command_env())
    os.chdir(cwd)
    try:
        yield
    finally:
        os.chdir(here)
        _set_environment(before)


def _set_environment(wanted: dict) -> None:
    for key in [k for k in os.environ if k not in wanted]:
        del os.environ[key]
    for key, value in wanted.items():
        if os.environ.get(key) != value:
            os.environ[key] = value


def run_in_process(argv: list[str], cwd: Path) -> tuple[int | None, str, str, float]:
    """(exit code, stdout, stderr, CPU seconds) of ``morf ARGV`` run in this process in ``cwd``:
    what :func:`run_command` gives, without starting Python. Main thread only (the commands set a
    SIGINT handler), one at a time (it changes the working directory)."""
    from morf.cli.main import main

    usage0 = resource.getrusage(resource.RUSAGE_SELF)
    with _captured_output() as read, _as_a_fresh_process(cwd), warnings.catch_warnings(record=True) as shown:
        warnings.resetwarnings()  # also forgets which warnings earlier cases have shown
        warnings.simplefilter("default")
        for category in _HIDDEN_BY_DEFAULT:
            warnings.simplefilter("ignore", category)
        try:
            rc = main(argv)
        except SystemExit as e:  # argparse's usage errors, as `python -m morf.cli.main` ends on them
            rc = e.code if isinstance(e.code, int) else 0 if e.code is None else 1
            if isinstance(e.code, str):
                print(e.code, file=sys.stderr)
        except BaseException:  # what the interpreter prints for an uncaught exception, and its exit code
            traceback.print_exc(file=sys.stderr)
            rc = 1
        for w in shown:
            sys.stderr.write(warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line))
    usage1 = resource.getrusage(resource.RUSAGE_SELF)
    stdout, stderr = read()
    return rc, stdout, stderr, usage1.ru_utime + usage1.ru_stime - usage0.ru_utime - usage0.ru_stime


def _writable(root: Path) -> bool:
    """Whether a new file can be made in ``root`` (tried, not asked: root ignores permissions)."""
    probe = root / ".hostile-probe"
    try:
        probe.touch()
    except OSError:
        return False
    probe.unlink()
    return True


def make_read_only(root: Path) -> str | None:
    """Take write permission off everything under ``root``: chmod, and where that does not bite
    (root writes anyway) the immutable attribute, which binds root too. Returns how (``chmod`` or
    ``chattr``), or None when neither bites here."""
    for dirpath, dirnames, filenames in os.walk(root):
        for name in [os.path.join(dirpath, n) for n in filenames] + [dirpath]:
            os.chmod(name, os.stat(name).st_mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    if not os.access(root, os.W_OK) and not _writable(root):
        return "chmod"
    if shutil.which("chattr") and subprocess.run(["chattr", "-R", "+i", str(root)], capture_output=True).returncode == 0:
        if not _writable(root):
            return "chattr"
    make_writable(root)
    return None


def make_writable(root: Path) -> None:
    """Undo :func:`make_read_only`."""
    if shutil.which("chattr"):
        subprocess.run(["chattr", "-R", "-i", str(root)], capture_output=True)
    for dirpath, dirnames, filenames in os.walk(root):
        for name in [dirpath] + [os.path.join(dirpath, n) for n in dirnames + filenames]:
            try:
                if not os.path.islink(name):
                    os.chmod(name, os.stat(name).st_mode | stat.S_IWUSR)
            except OSError:
                pass


HOLDER = """
import sys
from morf.io.lock import project_lock
with project_lock(sys.argv[1], sys.argv[2], command="morf train P --name second"):
    print("held", flush=True)
    sys.stdin.read()
"""


def start_holder(project: Path, stage: str) -> subprocess.Popen:
    """A second morf process holding ``stage``'s lock of ``project`` until its stdin closes."""
    p = subprocess.Popen([sys.executable, "-c", HOLDER, str(project), stage], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=command_env())
    line = p.stdout.readline()
    if line.strip() != "held":
        p.kill()
        raise RuntimeError(f"the lock holder did not start: {p.stderr.read().strip()[-2000:]}")
    return p


def stop_holder(p: subprocess.Popen) -> None:
    try:
        p.stdin.close()
        p.wait(timeout=30)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()


def leave_stale_lock(project: Path, stage: str) -> None:
    """A lock taken by a process that was then killed with SIGKILL (its lock file stays)."""
    p = start_holder(project, stage)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()


def run_case(case, fixture: Fixture, folder: Path, in_process: bool = False) -> Outcome:
    """Lay out ``case`` in ``folder``, run its command there (in a fresh process, or in this one
    with :func:`run_in_process`), record what changed."""
    folder.mkdir(parents=True)
    if case.needs == "project":
        shutil.copytree(fixture.project, folder / "P", symlinks=True)
    elif case.needs == "avatar":
        shutil.copytree(fixture.project / "avatar", folder / "A", symlinks=True)
    values = {"fixture": str(fixture.project), "here": str(folder), "bvh": str(fixture.bvh),
              "bomb": str(fixture.bomb)}
    if case.setup is not None:
        case.setup(folder, fixture)
    argv = [a.format(**values) for a in shlex.split(case.command)]
    out = Outcome(argv=argv, folder=folder)
    read_only = folder / case.read_only if case.read_only else None
    try:
        if read_only is not None and make_read_only(read_only) is None:
            out.skipped = ("neither chmod nor chattr +i takes write permission away from this user here; "
                           "the read-only project cannot be made")
            return out
        out.before = snapshot(folder)
        holder = start_holder(folder / "P", case.lock) if case.lock else None
        try:
            out.holder_pid = holder.pid if holder else None
            t0 = time.perf_counter()
            if in_process:
                out.rc, out.stdout, out.stderr, out.cpu_seconds = run_in_process(argv, folder)
            else:
                out.rc, out.stdout, out.stderr, out.cpu_seconds = run_command(morf_command() + argv, folder)
            out.seconds = time.perf_counter() - t0
        finally:
            if holder is not None:
                stop_holder(holder)
        out.after = snapshot(folder)
    finally:
        if read_only is not None:
            make_writable(read_only)
    return out
