"""Arrays on disk as .npz, always without pickle (safe to open from untrusted projects).

Reading is bounded: an .npz is a zip, and a few megabytes of zip can expand to gigabytes, so
every member's size is checked, from the zip directory and from the array header it declares,
before anything is read.
"""

from __future__ import annotations

import math
import os
import zipfile
import zlib
from pathlib import Path

import numpy as np

from morf.errors import MorfError, ProjectError
from morf.io.atomic import atomic_path

# The most one array of a file may take in memory: files a user brings (motions, keypoints) are
# small, files morf wrote into a project hold at most a long capture's training frames.
USER_FILE_MAX_BYTES = 256 * 2**20
PROJECT_FILE_MAX_BYTES = 32 * 2**30
# All the arrays of one file together may take this many times the limit of one.
TOTAL_FACTOR = 4

_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")  # a zip with members; an empty zip


def save_npz(target: str | os.PathLike, **arrays: np.ndarray) -> None:
    """Atomically write arrays to ``target`` (.npz, compressed). Object arrays are refused."""
    clean = {}
    for name, a in arrays.items():
        a = np.asarray(a)
        if a.dtype == object:
            raise TypeError(f"array {name!r} has dtype object; store strings as str arrays")
        clean[name] = a
    with atomic_path(target, suffix=".npz") as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **clean)


def size_text(n: int) -> str:
    """A byte count for messages: ``812 bytes``, ``3.5 MiB``, ``2.0 GiB``."""
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n} bytes"


def default_max_bytes(error: type[MorfError]) -> int:
    """The per-array limit for a file whose errors are ``error``: the project limit for project
    files (:class:`ProjectError` and its kinds), the user-file limit for everything else."""
    return PROJECT_FILE_MAX_BYTES if issubclass(error, ProjectError) else USER_FILE_MAX_BYTES


def _check_archive(path: Path, error: type[MorfError]) -> None:
    """Refuse a file that is not a zip at all, saying what it is instead (numpy would otherwise
    try it as a pickle and suggest ``allow_pickle``)."""
    with open(path, "rb") as f:
        head = f.read(len(_NPY_MAGIC))
    if head.startswith(_ZIP_MAGICS):
        return
    if not head:
        raise error(f"{path} is empty, not an .npz archive")
    if head.startswith(_NPY_MAGIC):
        raise error(f"{path} is a single .npy array, not an .npz archive; save it with numpy.savez "
                    "(or rename it to .npy if that is what is wanted)")
    raise error(f"{path} is not an .npz archive (the zip of .npy arrays numpy.savez writes); "
                "check that this is the file you meant")


def _array_header(member) -> tuple[tuple[int, ...], np.dtype] | None:
    """(shape, dtype) a .npy member declares, or None when the member is no .npy array."""
    if member.read(len(_NPY_MAGIC)) != _NPY_MAGIC:
        return None
    version = tuple(member.read(2))
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(member)
    elif version in ((2, 0), (3, 0)):
        shape, _, dtype = np.lib.format.read_array_header_2_0(member)
    else:
        raise ValueError(f"unknown .npy format version {version}")
    return tuple(int(s) for s in shape), dtype


def _too_big(path: Path, what: str, size: int, limit: int, detail: str, error: type[MorfError]) -> MorfError:
    return error(f"{path}: {what} would take {size_text(size)} in memory{detail}, more than the {size_text(limit)} "
                 "allowed; check that this is the file you meant")


def load_npz(path: str | os.PathLike, *, error: type[MorfError] = ProjectError, skip_pickled: bool = False,
             max_bytes: int | None = None) -> dict[str, np.ndarray]:
    """Load every array of an .npz into memory with ``allow_pickle=False``: the one .npz reader.

    Strings stored as text (``np.array('male')``) or bytes (``np.array(b'male')``) load as they
    are; arrays of Python objects are never unpickled.

    Args:
        error: the :class:`~morf.errors.MorfError` raised for a missing, unreadable or oversized
            file (ProjectError for project files, InputError for files a user brings).
        skip_pickled: leave arrays of Python objects (and members that are no .npy array) out of
            the result instead of refusing the file (public motion files carry such metadata
            beside plain arrays).
        max_bytes: the most one array may take in memory, checked against the zip's member size
            and the array's declared shape before it is read (default
            :func:`default_max_bytes`); all arrays together may take ``TOTAL_FACTOR`` times it.
    Returns:
        name -> array, in the file's order.
    """
    path = Path(path)
    if not path.is_file():
        raise error(f"missing file: {path}")
    limit = default_max_bytes(error) if max_bytes is None else int(max_bytes)
    out = {}
    try:
        _check_archive(path, error)
        with zipfile.ZipFile(path) as zf:
            members = [m for m in zf.infolist() if not m.is_dir()]
            for m in members:
                if m.file_size > limit:
                    raise _too_big(path, f"member {m.filename!r}", m.file_size, limit,
                                   f" (stored in {size_text(m.compress_size)})", error)
            total = sum(m.file_size for m in members)
            if total > TOTAL_FACTOR * limit:
                raise _too_big(path, f"its {len(members)} members together", total, TOTAL_FACTOR * limit, "", error)
            for m in members:
                key = m.filename[:-4] if m.filename.endswith(".npy") else m.filename
                with zf.open(m) as member:
                    header = _array_header(member)
                if header is None or header[1].hasobject:
                    if skip_pickled:
                        continue
                    what = "is no .npy array" if header is None else "holds Python objects (pickled)"
                    raise error(f"{path}: array {key!r} {what}, which is not loaded for safety")
                shape, dtype = header
                size = math.prod(shape) * dtype.itemsize
                if size > limit:
                    raise _too_big(path, f"array {key!r}", size, limit, f" ({'x'.join(map(str, shape))} {dtype})",
                                   error)
                with zf.open(m) as member:
                    out[key] = np.lib.format.read_array(member, allow_pickle=False)
    except (ValueError, OSError, EOFError, RuntimeError, NotImplementedError, zipfile.BadZipFile, zlib.error) as e:
        raise error(f"cannot read {path}: damaged .npz file ({e})") from None
    return out


def first_outside(values: np.ndarray, low, high) -> tuple[tuple[int, ...], float] | None:
    """(index, value) of the first entry of ``values`` (row-major, so the lowest index along the
    first axis: a motion's first bad frame) that is NaN, infinite or outside [``low``, ``high``]
    (scalars or arrays broadcasting against ``values``); None when every entry is in range.
    Numbers read from a file are checked with it where they enter."""
    a = np.asarray(values, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        bad = ~((a >= low) & (a <= high))  # NaN compares False either way
    if not bad.any():
        return None
    flat = int(np.argmax(bad.reshape(-1)))
    index = tuple(int(i) for i in np.unravel_index(flat, a.shape))
    return index, float(a.reshape(-1)[flat])
