"""Opening motion files of any supported kind, and listing a folder of them for the studio."""

from __future__ import annotations

import os
import threading
import zipfile
from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.motion.clip import MotionClip, clip_from_arrays

MOTION_SUFFIXES = (".bvh", ".npz")
BUILTIN_MOTIONS = Path(__file__).resolve().parents[2] / "resources" / "motions"

_MODEL_LOCK = threading.Lock()
_MODEL = None


def read_npz(path: Path) -> dict[str, np.ndarray]:
    """All arrays of an .npz, without pickle; InputError for a missing or unreadable file."""
    if not path.is_file():
        raise InputError(f"no such motion file: {path}")
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except ValueError as e:
        if "pickle" in str(e).lower():
            raise InputError(f"{path}: holds Python objects (pickled arrays), which are not loaded for safety") from None
        raise InputError(f"{path}: cannot read: {e}") from None
    except (OSError, zipfile.BadZipFile, EOFError) as e:
        raise InputError(f"{path}: not a readable .npz file ({e})") from None


def _default_model():
    global _MODEL
    with _MODEL_LOCK:
        if _MODEL is None:
            from morf.body import load_body_model

            _MODEL = load_body_model("anny")
        return _MODEL


def load_motion(path: str | os.PathLike, model=None, shape=None, config=None) -> MotionClip:
    """Open a motion as an Anny :class:`MotionClip`, whatever its kind (by suffix and content):

    - ``.bvh``: read and retargeted (:func:`morf.motion.convert.retarget`);
    - ``.npz`` written by :func:`morf.motion.clip.save_clip`: loaded as it is;
    - ``.npz`` from AMASS (SMPL-H / SMPL-X): read and retargeted.

    ``model`` (Anny) and ``shape`` (1, 6) are only needed for retargeting; a shared Anny model
    is loaded when none is given. ``config`` is a :class:`~morf.motion.convert.RetargetConfig`.
    Raises:
        InputError: missing file, unknown suffix, or a file of the right suffix but wrong content.
    """
    from morf.motion.convert import RetargetConfig, retarget

    path = Path(path).expanduser()
    suffix = path.suffix.lower()
    if suffix not in MOTION_SUFFIXES:
        raise InputError(f"{path}: not a motion file (expected .bvh or .npz)")
    if not path.is_file():
        raise InputError(f"no such motion file: {path}")
    config = config or RetargetConfig()
    if suffix == ".bvh":
        from morf.motion.bvh import read_bvh

        source = read_bvh(path)
    else:
        arrays = read_npz(path)
        if "morf_motion_version" in arrays:
            return clip_from_arrays(arrays, path)
        if not ({"poses", "trans"} <= set(arrays) or {"root_orient", "pose_body"} <= set(arrays)):
            raise InputError(f"{path}: not a motion: expected a MoRF motion clip or AMASS arrays "
                             f"('poses' and 'trans'); found {', '.join(sorted(arrays)) or 'nothing'}")
        from morf.motion.amass import read_amass

        source = read_amass(path, arrays)
    return retarget(source, model if model is not None else _default_model(), shape, config)


def motion_library(folder: str | os.PathLike | None = None) -> list[tuple[str, Path]]:
    """(name, path) of every .bvh / .npz under ``folder`` (default: the bundled motions), sorted
    by name; the name is the path relative to ``folder`` without its suffix. Empty when the
    folder does not exist."""
    root = Path(folder).expanduser() if folder is not None else BUILTIN_MOTIONS
    if not root.is_dir():
        return []
    files = [p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in MOTION_SUFFIXES]
    return sorted((p.relative_to(root).with_suffix("").as_posix(), p) for p in files)
