"""Listing the motions in a folder for the live render panel, cheaply and safely.

A folder is listed only when the user commits its path (Enter, a drop, a recent folder), on the
browser's own thread (:class:`studio.motion_browser.MotionBrowser`), never per keystroke: a path
such as ``/`` would otherwise walk the whole file system on the UI thread. The walk is bounded
(:data:`MAX_DEPTH` folders down, :data:`MAX_FILES` candidates), skips what it may not read, hidden
folders, and the insides of capture projects and exported avatars (their ``mesh.npz``,
``fits/fits.npz``, ``runs/.cache/frames-*.npz`` are no motions to pick).

Whether a file is a motion is decided from its header alone: a BVH's first word, an .npz's array
names and shapes read from each member's .npy header (no array data), told apart by the motion
readers' own rule (:func:`morf.motion.formats.npz_motion_kind`). Files that fail are kept, greyed,
with the reason.
"""

from __future__ import annotations

import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.capture.project import MANIFEST as PROJECT_MANIFEST
from morf.export.avatar_folder import MANIFEST as AVATAR_MANIFEST
from morf.motion.formats import npz_motion_kind
from morf.motion.library import MOTION_SUFFIXES

MAX_DEPTH = 4  # folders below the chosen one that are listed
MAX_FILES = 500  # .bvh / .npz files looked at; the listing says when it stopped there
MAX_MEMBERS = 64  # arrays in one .npz (motions hold a handful)
MAX_HEADER_BYTES = 4096  # a .npy header is well under this
MAX_BVH_HEADER_BYTES = 256 * 1024  # a BVH's hierarchy and MOTION header (hundreds of joints fit in far less)
SYSTEM_FOLDERS = ("/proc", "/sys", "/dev")  # the kernel's own files: never motions, and slow or unreadable


@dataclass(frozen=True)
class MotionEntry:
    """One .bvh / .npz under the listed folder: ``name`` relative to it, ``kind`` (``"bvh"`` or a
    :func:`npz_motion_kind` kind) when it is a motion, else ``reason`` why it is not."""

    path: Path
    name: str
    kind: str | None
    reason: str | None = None

    @property
    def is_motion(self) -> bool:
        return self.kind is not None


@dataclass(frozen=True)
class MotionScan:
    """A folder's listing: motions first (by name), then the files that are not, then notes
    (folders skipped, limits reached); ``error`` when the folder itself cannot be listed."""

    folder: str
    entries: tuple[MotionEntry, ...] = ()
    notes: tuple[str, ...] = ()
    error: str | None = None

    @property
    def motions(self) -> tuple[MotionEntry, ...]:
        return tuple(e for e in self.entries if e.is_motion)


@dataclass(frozen=True)
class _Header:
    """What ``npz_motion_kind`` reads of an array: its shape (and ndim), not its data."""

    shape: tuple[int, ...]
    dtype: np.dtype

    @property
    def ndim(self) -> int:
        return len(self.shape)


def npz_headers(path: Path) -> dict[str, _Header]:
    """Array name -> shape and dtype of an .npz, from each member's .npy header only.
    Raises ValueError (not an .npz, a damaged one, too many members) or OSError."""
    try:
        with zipfile.ZipFile(path) as z:
            names = [n for n in z.namelist() if n.endswith(".npy")]
            if len(names) > MAX_MEMBERS:
                raise ValueError(f"{len(names)} arrays, more than a motion holds")
            out = {}
            for n in names:
                with z.open(n) as f:
                    version = np.lib.format.read_magic(f)
                    reader = {(1, 0): np.lib.format.read_array_header_1_0,
                              (2, 0): np.lib.format.read_array_header_2_0}.get(version)
                    if reader is None:
                        raise ValueError(f"array {n[:-4]} has .npy format {version}")
                    shape, _, dtype = reader(f, max_header_size=MAX_HEADER_BYTES)
                out[n[:-4]] = _Header(tuple(int(s) for s in shape), np.dtype(dtype))
            return out
    except zipfile.BadZipFile:
        raise ValueError("not an .npz archive") from None


def _shape_problem(kind: str, arrays: dict[str, _Header]) -> str | None:
    """The cheap shape checks of a motion kind's main arrays (the readers check the numbers)."""
    if any(a.dtype.hasobject for a in arrays.values()):
        return "holds pickled objects, which are never loaded"
    if kind in ("clip", "player", "fits"):
        r, t = arrays.get("rotvecs"), arrays.get("transl")
        if r is None or t is None:
            return "rotvecs or transl missing"
        if r.ndim != 3 or r.shape[2] != 3 or t.shape != (r.shape[0], 3):
            return f"rotvecs {r.shape} and transl {t.shape} are not (T, J, 3) and (T, 3)"
    if kind == "amass":
        p = arrays.get("poses")
        if p is not None and (p.ndim != 2 or p.shape[1] not in (156, 165)):
            return f"poses {p.shape} is not (T, 156) SMPL-H or (T, 165) SMPL-X"
    if kind == "smpl":
        p = arrays.get("smpl_poses", arrays.get("poses"))
        if p.ndim != 2 or p.shape[1] != 72:
            return f"poses {p.shape} is not (T, 72) SMPL"
    if any(0 in a.shape for a in arrays.values() if a.ndim):
        return "holds no frames"
    return None


def check_motion_file(path: Path) -> tuple[str | None, str | None]:
    """(kind, None) when ``path``'s header says it is a motion, else (None, the reason)."""
    try:
        if path.suffix.lower() == ".bvh":
            problem = bvh_problem(path)
            return (None, problem) if problem else ("bvh", None)
        arrays = npz_headers(path)
    except (OSError, ValueError, EOFError) as e:
        return None, f"cannot be read: {e}" if isinstance(e, OSError) else str(e)
    kind = npz_motion_kind(arrays)  # type: ignore[arg-type]  (reads keys, shapes and ndim only)
    if kind is None:
        names = ", ".join(list(arrays)[:5]) or "no arrays"
        return None, f"not a motion (arrays: {names})"
    problem = _shape_problem(kind, arrays)
    return (None, problem) if problem else (kind, None)


def bvh_problem(path: Path) -> str | None:
    """What keeps a BVH from playing, from its hierarchy and MOTION header alone (the first
    :data:`MAX_BVH_HEADER_BYTES`; no frame data is parsed): not a BVH, a broken hierarchy, no
    channels or frames, more values in a frame than channels, or a skeleton that no body can be
    matched to (the retargeting's own name matcher). None when it plays."""
    from morf.errors import InputError
    from morf.motion.bvh import parse_hierarchy  # the reader's own parser, so the two cannot disagree
    from morf.motion.name_matching import map_for
    from morf.motion.skeleton import SourceSkeleton

    with open(path, "rb") as f:
        head = f.read(MAX_BVH_HEADER_BYTES)
    lines = head.decode("utf-8", errors="replace").lstrip("\ufeff").splitlines()
    if not lines or lines[0].strip().upper() != "HIERARCHY":
        return "not a BVH file (no HIERARCHY header)"
    try:
        parsed, motion = parse_hierarchy(lines, path)
    except InputError as e:
        return str(e).removeprefix(f"{path}: ")
    channels = sum(len(c) for c in parsed.channels)
    if not parsed.names or not channels:
        return "its hierarchy declares no joints or no channels"
    rows = [ln.split() for ln in lines[motion + 1:motion + 5] if ln.strip()]
    frames = next((r[1] for r in rows if len(r) == 2 and r[0].lower() == "frames:"), None)
    if frames is None or not frames.isdigit() or int(frames) < 1:
        return "no frames ('Frames:' after MOTION)"
    if len(rows) > 2 and len(rows[2]) > channels:
        return f"a frame has {len(rows[2])} values, but the hierarchy declares {channels} channels"
    skeleton = SourceSkeleton(tuple(parsed.names), tuple(parsed.parents), np.asarray(parsed.offsets, np.float64), "y")
    try:
        map_for(skeleton)
    except InputError as e:
        if str(e).startswith("cannot match this skeleton"):
            return str(e)
    return None


def _internal(folder: Path) -> str | None:
    """Why a folder's insides are not listed: a capture project or an exported avatar."""
    if (folder / PROJECT_MANIFEST).is_file():
        return "a capture project"
    if (folder / AVATAR_MANIFEST).is_file():
        return "an exported avatar"
    return None


def scan_motions(folder: str | os.PathLike, *, max_depth: int = MAX_DEPTH, max_files: int = MAX_FILES) -> MotionScan:
    """List the .bvh / .npz files under ``folder`` (bounded, breadth first) and check each one's header."""
    text = str(folder)
    root = Path(text).expanduser()
    if not text.strip():
        return MotionScan(text, error="no folder given")
    if not root.is_dir():
        return MotionScan(text, error=f"not a folder: {root}" if root.exists() else f"folder not found: {root}")
    why = _internal(root)
    if why is not None:
        return MotionScan(text, error=f"{root} is {why}: its files are no motions; choose a folder of "
                                      ".bvh / .npz motion files")
    files: list[Path] = []
    notes: list[str] = []
    skipped_internal = unreadable = 0
    deep = full = False
    level = [root]
    for depth in range(max_depth + 1):
        below: list[Path] = []
        for d in level:
            try:
                with os.scandir(d) as it:
                    items = sorted(it, key=lambda e: e.name)
            except OSError:  # PermissionError, a folder gone meanwhile, /proc oddities
                unreadable += 1
                continue
            for e in items:
                if e.name.startswith("."):
                    continue
                try:
                    if e.is_dir(follow_symlinks=False):
                        sub = Path(e.path)
                        if e.path in SYSTEM_FOLDERS:
                            continue
                        if _internal(sub) is not None:
                            skipped_internal += 1
                        elif depth < max_depth:
                            below.append(sub)
                        else:
                            deep = True
                    elif e.is_file() and Path(e.name).suffix.lower() in MOTION_SUFFIXES:
                        if len(files) >= max_files:
                            full = True
                            break
                        files.append(Path(e.path))
                except OSError:
                    unreadable += 1
            if full:
                break
        if full or not below:
            break
        level = below
    entries = []
    for p in files:
        kind, reason = check_motion_file(p)
        entries.append(MotionEntry(p, p.relative_to(root).as_posix(), kind, reason))
    entries.sort(key=lambda e: (not e.is_motion, e.name))
    if full:
        notes.append(f"stopped after {max_files} files; choose a smaller folder")
    if deep:
        notes.append(f"folders more than {max_depth} levels down are not listed")
    if skipped_internal:
        notes.append(f"{skipped_internal} project / avatar folder(s) left out (their files are no motions)")
    if unreadable:
        notes.append(f"{unreadable} folder(s) could not be read and were skipped")
    return MotionScan(text, tuple(entries), tuple(notes))
