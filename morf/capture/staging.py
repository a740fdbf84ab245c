"""Replacing a project folder whole: build it beside the target, then swap.

A stage that rewrites a whole project (ingest) writes into a hidden folder in the target's
parent and swaps it in at the end, so a failure or Ctrl-C at any point leaves the previous
project exactly as it was. On Linux the swap is one atomic ``renameat2(RENAME_EXCHANGE)``;
elsewhere two renames (a crash between them leaves the old project under a hidden name
beside the target, never a half-written one).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Iterator

from morf.capture.project import FITS_DIR, CaptureProject
from morf.errors import ProjectError
from morf.io.atomic import process_umask
from morf.io.lock import held_locks

# Folders whose content was made from the current frames; replacing the frames orphans them.
LATER_STAGES = (FITS_DIR, "runs", "avatar", "ground_truth")


def check_replaceable(root: Path, force: bool) -> bool:
    """May ``root`` be (re)written by ingest? Returns whether a project is already there."""
    if not root.exists():
        return False
    if not root.is_dir():
        raise ProjectError(f"{root} exists and is not a folder")
    if not CaptureProject.is_project(root):
        if any(root.iterdir()):
            raise ProjectError(f"{root} exists, is not empty and is not a MoRF project; choose a new folder")
        return False
    busy = held_locks(root)
    if busy:
        stage, holder = busy[0]
        raise ProjectError(f"{root} is being written by another morf process (pid {holder.get('pid', '?')}, "
                           f"`{holder.get('command', '?')}`, {stage}); wait for it to finish before ingesting again")
    later = later_stages(root)
    if later and not force:
        raise ProjectError(f"{root} already holds {', '.join(later)} made from its current frames; "
                           f"pass --force to replace the whole project")
    return True


def later_stages(root: Path) -> list[str]:
    """The folders of later stages (fits, runs, avatar, ...) that hold anything in the project ``root``."""
    return [d for d in LATER_STAGES if (root / d).is_dir() and any((root / d).iterdir())]


@contextlib.contextmanager
def staged_folder(root: Path) -> Iterator[Path]:
    """Yield an empty hidden folder beside ``root``; on success it replaces ``root``.

    On any exception (including KeyboardInterrupt) the staging folder is deleted, ``root`` is
    untouched (a folder the user had stays as it was) and the parent folders made for it are
    removed again: a failed ingest leaves nothing behind.

    A replaced project that held later stages' work (fits, training runs, an avatar: hours of a
    user's time, which ingest did not write) is not deleted: it is kept beside the new one as
    ``<name>.replaced-<date>-<time>``, and a note says so.
    """
    root = Path(root).absolute()
    made = missing_parents(root)
    try:
        root.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{root.name}.ingest-", dir=root.parent))
        os.chmod(staging, 0o777 & ~process_umask())  # mkdtemp makes it private; a project is an ordinary folder
    except OSError as e:
        _remove_empty(made)
        raise ProjectError(f"cannot write in {root.parent}: {e.strerror or e}") from None
    try:
        yield staging
        swap_in(staging, root)
        if later_stages(staging):
            keep = root.with_name(f"{root.name}.replaced-{time.strftime('%Y%m%d-%H%M%S')}")
            os.rename(staging, keep)
            print(f"note: the replaced project's fits, runs and avatar are kept in {keep}", file=sys.stderr)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        _remove_empty(made)
        raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def missing_parents(root: Path) -> list[Path]:
    """The parent folders of ``root`` that do not exist yet, innermost first."""
    out = []
    for parent in root.parents:
        if parent.exists():
            break
        out.append(parent)
    return out


def _remove_empty(folders: list[Path]) -> None:
    """Remove ``folders`` (innermost first) while they are empty; one that holds anything stays."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            return


def swap_in(staging: Path, root: Path) -> None:
    """Put ``staging`` at ``root``; whatever was at ``root`` ends up at ``staging`` (deleted by the caller)."""
    if not root.exists():
        os.rename(staging, root)
        return
    if _exchange(staging, root):
        return
    aside = staging.with_name(staging.name + ".old")
    os.rename(root, aside)
    os.rename(staging, root)
    os.rename(aside, staging)


def _exchange(a: Path, b: Path) -> bool:
    """Atomically exchange two paths (Linux renameat2); False where unsupported."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    return fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0
