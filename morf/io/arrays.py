"""Arrays on disk as .npz, always without pickle (safe to open from untrusted projects)."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from morf.errors import ProjectError
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


def load_npz(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Load every array of an .npz into memory with ``allow_pickle=False``."""
    path = Path(path)
    if not path.is_file():
        raise ProjectError(f"missing file: {path}")
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (ValueError, OSError, zipfile.BadZipFile, EOFError) as e:
        raise ProjectError(f"cannot read {path}: {e}") from None
