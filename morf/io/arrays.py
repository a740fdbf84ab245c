"""Arrays on disk as .npz, always without pickle (safe to open from untrusted projects)."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from morf.errors import MorfError, ProjectError
from morf.io.atomic import atomic_path


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


def load_npz(path: str | os.PathLike, *, error: type[MorfError] = ProjectError,
             skip_pickled: bool = False) -> dict[str, np.ndarray]:
    """Load every array of an .npz into memory with ``allow_pickle=False``: the one .npz reader.

    Strings stored as text (``np.array('male')``) or bytes (``np.array(b'male')``) load as they
    are; arrays of Python objects are never unpickled.

    Args:
        error: the :class:`~morf.errors.MorfError` raised for a missing or unreadable file
            (ProjectError for project files, InputError for files a user brings).
        skip_pickled: leave arrays of Python objects out of the result instead of refusing the
            file (public motion files carry such metadata beside plain arrays).
    Returns:
        name -> array, in the file's order.
    """
    path = Path(path)
    if not path.is_file():
        raise error(f"missing file: {path}")
    out = {}
    try:
        with np.load(path, allow_pickle=False) as z:
            for k in z.files:
                try:
                    out[k] = z[k]
                except ValueError as e:
                    if "pickle" not in str(e).lower():
                        raise
                    if not skip_pickled:
                        raise error(f"{path}: array {k!r} holds Python objects (pickled), which are not "
                                    "loaded for safety") from None
    except (ValueError, OSError, zipfile.BadZipFile, EOFError) as e:
        raise error(f"cannot read {path}: not a readable .npz file ({e})") from None
    return out
