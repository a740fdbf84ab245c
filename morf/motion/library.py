"""Opening motion files of any supported kind, and listing a folder of them for the studio."""

from __future__ import annotations

import os
import threading
from pathlib import Path

from morf.errors import InputError
from morf.io import load_npz
from morf.motion.checks import check_clip, check_fps
from morf.motion.clip import MotionClip, clip_from_arrays
from morf.motion.formats import not_a_motion, npz_motion_kind, player_clip
from morf.resources import MOTIONS

MOTION_SUFFIXES = (".bvh", ".npz")
BUILTIN_MOTIONS = MOTIONS

_MODEL_LOCK = threading.Lock()
_MODEL = None


def shared_body_model():
    """The Anny body model shared by motion loading (loaded once, on first use)."""
    global _MODEL
    with _MODEL_LOCK:
        if _MODEL is None:
            from morf.body import load_body_model

            _MODEL = load_body_model("anny")
        return _MODEL


def load_motion(path: str | os.PathLike, model=None, shape=None, config=None,
                source_fps: float | None = None) -> MotionClip:
    """Open a motion as an Anny :class:`MotionClip`, whatever its kind (by suffix, then content;
    :mod:`morf.motion.formats`):

    - ``.bvh``: read and retargeted (:func:`morf.motion.convert.retarget`);
    - ``.npz`` written by :func:`morf.motion.clip.save_clip`, or Anny poses (``rotvecs``,
      ``transl``, ``fps``): loaded as they are;
    - ``.npz`` from AMASS (SMPL-H / SMPL-X), AIST++, plain SMPL, or SMPL / SMPL-X parameters split
      by body part (``global_orient``, ``body_pose``, ...): read and retargeted;
    - a capture's ``fits/fits.npz``: turned upright and put on the ground for ``shape``.

    ``model`` (Anny) and ``shape`` (1, 6) are only needed for retargeting; a shared Anny model
    is loaded when none is given. ``config`` is a :class:`~morf.motion.convert.RetargetConfig`.
    ``source_fps`` is the frame rate of files that store none (AIST++ and plain SMPL, fits outside
    a project, Anny poses without ``fps``); each kind has its default otherwise.
    Raises:
        InputError: missing file, unknown suffix, a file of the right suffix but wrong content, or
            numbers out of range (:mod:`morf.motion.checks`).
    """
    path = Path(path).expanduser()
    suffix = path.suffix.lower()
    if suffix not in MOTION_SUFFIXES:
        raise InputError(f"{path}: not a motion file (expected .bvh or .npz)")
    if path.is_dir():
        raise InputError(f"{path} is a folder, not a motion file; give one .bvh or .npz file")
    if not path.is_file():
        raise InputError(f"no such motion file: {path}")
    if source_fps is not None:
        source_fps = check_fps(source_fps, "the frame rate given for the motion")
    clip = _read_motion(path, model, shape, config, source_fps)
    check_clip(clip, f"{path} (as retargeted onto the body)")  # what every reader hands the player and the export
    return clip


def _read_motion(path: Path, model, shape, config, source_fps: float | None) -> MotionClip:
    """:func:`load_motion` by kind, each reader checking the numbers it reads. ``shape`` may be a
    function giving it, called only for a motion that is retargeted (a bad file is refused before
    the body's shape is worked out, and an Anny clip never needs it)."""
    if path.suffix.lower() == ".bvh":
        from morf.motion.bvh import read_bvh

        source = read_bvh(path)
    else:
        arrays = load_npz(path, error=InputError, skip_pickled=True)
        kind = npz_motion_kind(arrays)
        if kind == "clip":
            return clip_from_arrays(arrays, path)
        if kind == "player":
            return player_clip(path, arrays, source_fps)
        if kind == "fits":
            from morf.motion.capture_fits import clip_from_fits

            return clip_from_fits(path, model if model is not None else shared_body_model(), _value(shape), source_fps,
                                  _retarget_config(config))
        if kind == "amass":
            from morf.motion.amass import read_amass

            source = read_amass(path, arrays, source_fps)
        elif kind == "smpl":
            from morf.motion.smpl import read_smpl

            source = read_smpl(path, arrays, source_fps)
        elif kind == "smpl-params":
            from morf.motion.smpl_params import read_smpl_params

            source = read_smpl_params(path, arrays, source_fps)
        else:
            raise not_a_motion(path, arrays)
    from morf.motion.convert import retarget

    return retarget(source, model if model is not None else shared_body_model(), _value(shape), _retarget_config(config))


def _retarget_config(config):
    """``config``, or the default :class:`~morf.motion.convert.RetargetConfig` (its module loads
    torch: only for a motion that is retargeted)."""
    if config is not None:
        return config
    from morf.motion.convert import RetargetConfig

    return RetargetConfig()


def _value(shape):
    return shape() if callable(shape) else shape


def motion_library(folder: str | os.PathLike | None = None) -> list[tuple[str, Path]]:
    """(name, path) of every .bvh / .npz under ``folder`` (default: the bundled motions), sorted
    by name; the name is the path relative to ``folder`` without its suffix. Empty when the
    folder does not exist."""
    root = Path(folder).expanduser() if folder is not None else BUILTIN_MOTIONS
    if not root.is_dir():
        return []
    files = [p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in MOTION_SUFFIXES]
    return sorted((p.relative_to(root).with_suffix("").as_posix(), p) for p in files)
