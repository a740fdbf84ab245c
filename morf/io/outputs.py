"""The one rule for a command's output path: a command writes only its own files.

- An output that does not exist yet, or an empty folder, is used as it is.
- An existing non-empty output is refused with one line, unless ``force`` is given.
- With ``force``, only the files the command itself writes are replaced, and only files the same
  command wrote there before (the folder's record of them) are deleted. Anything else stays.
- An output that is a capture project or lies inside one is refused even with ``force``: a command never writes into the project it reads unless that is its
  own place there (``PROJECT/avatar`` for ``morf export``), which the caller names as ``own_place``.
- A path that exists but is not a regular file or folder (``/dev/full``, a socket) is refused.

A folder's record of what a command wrote is ``.morf-output.json`` (``{"command", "files"}``);
the avatar folder keeps that list in its manifest instead (``morf/export/avatar_folder.py``).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from morf.errors import InputError
from morf.io.atomic import atomic_write_json, process_umask

RECORD = ".morf-output.json"
PROJECT_MANIFEST = "morf_project.json"  # morf.capture.project.MANIFEST, named here to stay import-light


@dataclass(frozen=True)
class OutputClaim:
    """What a command may do at its output path.

    Fields:
        path: the output (file or folder); existed: whether it existed before.
        previous: names (relative to a folder output) the same command wrote there before, which it
            may delete when it does not write them again.
        foreign: names in the folder the command did not write; they are never touched.
    """

    path: Path
    existed: bool
    previous: frozenset[str] = frozenset()
    foreign: frozenset[str] = frozenset()


def _listing(names) -> str:
    names = sorted(names)
    shown = ", ".join(names[:3])
    return shown + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _is_project(folder: Path) -> bool:
    return (folder / PROJECT_MANIFEST).is_file()


def _check_not_in_a_project(path: Path, command: str, own_place: Path | None) -> None:
    """Refuse a path that is a capture project or lies inside one (other than the command's
    ``own_place`` there). A folder that holds projects is an output like any other: its files
    are the user's, which the rule keeps, and the projects in it are never written."""
    resolved = path.resolve()
    if own_place is not None and resolved == Path(own_place).resolve():
        return
    for parent in (resolved, *resolved.parents):
        if _is_project(parent):
            where = "is the capture project" if parent == resolved else f"lies inside the capture project {parent}"
            raise InputError(f"{path} {where}; {command} never writes there: choose a folder outside the project")


def _check_kind(path: Path, want_dir: bool) -> None:
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    if want_dir and not stat.S_ISDIR(mode):
        raise InputError(f"{path} exists and is not a folder; choose a folder name for the output")
    if not want_dir and not stat.S_ISREG(mode):
        kind = "a folder" if stat.S_ISDIR(mode) else "not a regular file"
        raise InputError(f"{path} exists and is {kind}; choose a new file name for the output")


def read_record(folder: str | os.PathLike, command: str) -> frozenset[str]:
    """The files ``command`` recorded writing into ``folder`` (empty without a readable record of it)."""
    try:
        rec = json.loads((Path(folder) / RECORD).read_text())
    except (OSError, ValueError):
        return frozenset()
    if not isinstance(rec, dict) or rec.get("command") != command or not isinstance(rec.get("files"), list):
        return frozenset()
    return frozenset(n for n in rec["files"] if isinstance(n, str) and _plain_name(n))


def write_record(folder: str | os.PathLike, command: str, names) -> None:
    """Record the files ``command`` wrote into ``folder`` (read by the next ``--force``)."""
    atomic_write_json(Path(folder) / RECORD, {"command": command, "files": sorted(names)})


def _plain_name(name: str) -> bool:
    return bool(name) and name not in (".", "..") and "/" not in name and "\\" not in name and "\0" not in name


def claim_output_folder(path: str | os.PathLike, command: str, force: bool = False, *,
                        previous: frozenset[str] | None = None,
                        own_place: str | os.PathLike | None = None) -> OutputClaim:
    """Check that ``command`` may write the folder ``path``; an InputError (one line) when not.

    Args:
        command: the command as the user typed it (``"morf export"``), for messages and the record.
        force: replace the files this command writes (and delete those it wrote before) in an
            existing non-empty folder; never anything else.
        previous: the names the command wrote there before, when it keeps that list itself (the
            avatar manifest); default: the folder's ``.morf-output.json`` record.
        own_place: the command's own place inside a project (``PROJECT/avatar``): allowed there,
            and a re-run replaces the command's earlier output there without ``force`` (files of
            others are still kept, and still need ``force``).
    """
    path = Path(path)
    _check_kind(path, want_dir=True)
    _check_not_in_a_project(path, command, own_place)
    if not path.exists():
        return OutputClaim(path, False)
    try:
        entries = frozenset(p.name for p in path.iterdir())
    except PermissionError:
        raise InputError(f"cannot read the output folder {path}: permission denied") from None
    if previous is None:
        previous = read_record(path, command)
    ours = previous | {RECORD}
    foreign = frozenset(n for n in entries if n not in ours)
    at_own_place = own_place is not None and path.resolve() == Path(own_place).resolve()
    if entries and not force:
        if foreign:
            raise InputError(f"{path} already holds files {command} did not write ({_listing(foreign)}); choose a new "
                             f"folder, or pass --force to replace only the files {command} writes")
        if not at_own_place:
            raise InputError(f"{path} already holds an earlier output of {command}; pass --force to replace it, or "
                             "choose a new folder")
    return OutputClaim(path, True, frozenset(previous), foreign)


def claim_output_file(path: str | os.PathLike, command: str, force: bool = False) -> OutputClaim:
    """Check that ``command`` may write the file ``path`` (a video, a .glb); an InputError when not.

    An existing file is replaced only with ``force``; a folder, a device or a file inside a capture
    project is never written.
    """
    path = Path(path)
    _check_kind(path, want_dir=False)
    _check_not_in_a_project(path, command, None)
    if path.exists() and not force:
        raise InputError(f"{path} already exists; choose a new file name, or pass --force to replace it")
    if not path.parent.exists():
        return OutputClaim(path, False)
    if not os.access(path.parent, os.W_OK):
        raise InputError(f"cannot write {path}: the folder {path.parent} is not writable")
    return OutputClaim(path, path.exists())


@contextlib.contextmanager
def staged_folder(target: str | os.PathLike) -> Iterator[Path]:
    """A new private folder beside ``target`` to build an output in; removed again (with what was
    built in it, nothing else) when the block fails. The block moves it into place itself.

    Its permissions are a normal folder's (``mkdtemp`` makes owner-only folders)."""
    target = Path(target).absolute()  # "." has no name to put beside it
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    os.chmod(tmp, 0o777 & ~process_umask())
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
