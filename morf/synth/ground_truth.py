"""The arrays a synthetic capture knows to be true: the one reader and writer of
``ground_truth/gt.npz`` (every capture frame) and ``ground_truth/holdout.npz`` with the hold-out
images (a sequence of novel poses).

Paths come from :class:`~morf.capture.project.CaptureProject` (``ground_truth_path``,
``holdout_path``, ``holdout_frame_path``, ``holdout_mask_path``); every function here takes a
project or its folder. The other files of ``ground_truth/`` are listed in :mod:`morf.synth.capture`.

Format::

    gt.npz        per capture frame (N):
                    rotvecs (N, 104, 3), transl (N, 3), shape (1, 6): the true pose/shape
                    yaw (N,), phase (N,) str: "turn" | "hands"
                    keypoints3d (N, 23, 3) world; keypoints_true (N, 23, 3) projected,
                      no noise, no corruption (x, y, in-image flag)
                    corrupted (N,) bool, corruption (N,) str ("" when clean): frames whose
                      stored keypoints come from a wrong pose
                    slide_freqs (K, 2), slide_phases (K, 2), slide_coeffs (N, K, 2),
                      slide_weight (Vr,): the cloth sliding field (SlideField) and how much
                      each render vertex follows it; slide_grid (N, 32, 32, 2) sampled
                    loose_offset (V,): garment offset along the normals per model vertex (m)
                    vertex_regions (V, 5): skin, shirt, trousers, shoes, hair weights
                    valid (N,) bool, optional: frames the truth covers (all when absent)
    holdout.npz   rotvecs (M, 104, 3), transl (M, 3), shape (1, 6), yaw (M,), phase (M,) str,
                  keypoints (M, 23, 3) projected; camera K (3, 3), R (3, 3), t (3,), width, height
    holdout/frames/000000.png, holdout/masks/000000.png   the hold-out images, masks 0 or 255

Only rotvecs, transl and shape (and for the hold-out rotvecs and transl) must be present; a
reader names the other arrays it needs in ``require``. Arrays are returned as stored.
"""

from __future__ import annotations

import os
from dataclasses import MISSING, dataclass, fields
from pathlib import Path

import numpy as np

from morf.camera import PinholeCamera
from morf.capture.project import CaptureProject
from morf.errors import InputError, ProjectError
from morf.io import load_npz, read_image, save_npz, write_image
from morf.records import length_of


class GroundTruthError(ProjectError, InputError):
    """A synthetic capture's ground truth is missing or lacks an array: a damaged project and an
    unusable input at once, so either kind of handler catches it."""


@dataclass(frozen=True)
class GroundTruth:
    """The truth of every capture frame (``gt.npz``); the arrays are described in the module's
    docstring. ``valid`` is every frame when the file does not say; an optional array the file
    lacks is None (a reader asks for the ones it needs with ``require``)."""

    rotvecs: np.ndarray
    transl: np.ndarray
    shape: np.ndarray
    yaw: np.ndarray | None = None
    phase: np.ndarray | None = None
    keypoints3d: np.ndarray | None = None
    keypoints_true: np.ndarray | None = None
    corrupted: np.ndarray | None = None
    corruption: np.ndarray | None = None
    slide_freqs: np.ndarray | None = None
    slide_phases: np.ndarray | None = None
    slide_coeffs: np.ndarray | None = None
    slide_weight: np.ndarray | None = None
    slide_grid: np.ndarray | None = None
    loose_offset: np.ndarray | None = None
    vertex_regions: np.ndarray | None = None
    valid: np.ndarray | None = None

    num_frames = length_of("rotvecs")


@dataclass(frozen=True)
class HoldoutSequence:
    """The hold-out sequence (``holdout.npz``): novel poses rendered with the capture's garments
    and no cloth sliding. ``camera`` is the one it was rendered with, None when the file does not
    store one (the project's camera then applies)."""

    rotvecs: np.ndarray
    transl: np.ndarray
    shape: np.ndarray | None = None
    yaw: np.ndarray | None = None
    phase: np.ndarray | None = None
    keypoints: np.ndarray | None = None
    camera: PinholeCamera | None = None

    num_frames = length_of("rotvecs")


_CAMERA_KEYS = ("K", "R", "t", "width", "height")


def _project(project_or_root) -> CaptureProject:
    """A project as given, or the paths of the project in the folder named."""
    if isinstance(project_or_root, (str, os.PathLike)):
        return CaptureProject(Path(project_or_root), {})
    return project_or_root


def _required(cls) -> tuple[str, ...]:
    """The fields of ``cls`` with no default: the arrays every file must hold."""
    return tuple(f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING)


def _load(path: Path, what: str, cls, require: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The arrays of ``path``, checked for the fields ``cls`` always has and those in ``require``."""
    known = {f.name for f in fields(cls)}
    unknown = [k for k in require if k not in known]
    if unknown:
        raise ValueError(f"{cls.__name__} has no field {unknown[0]!r}")
    if not path.is_file():
        raise GroundTruthError(f"{path.parents[1]} has no {what} ({path.parent.name}/{path.name}); "
                               "only synthetic captures (morf synth) have one")
    d = load_npz(path, error=GroundTruthError)
    for key in _required(cls) + tuple(require):
        if key not in d:
            raise GroundTruthError(f"damaged {what} {path}: no {key!r} array; remake the capture with 'morf synth'")
    return d


# ---- gt.npz ---------------------------------------------------------------------------------
def has_ground_truth(project_or_root) -> bool:
    """Whether the project (or the project in this folder) has ``ground_truth/gt.npz``."""
    return _project(project_or_root).ground_truth_path.is_file()


def load_ground_truth(project_or_root, require: tuple[str, ...] = ()) -> GroundTruth:
    """The truth of every capture frame; raises :class:`GroundTruthError` when the file is missing
    or lacks rotvecs, transl, shape or an array named in ``require`` (field names of
    :class:`GroundTruth`)."""
    d = _load(_project(project_or_root).ground_truth_path, "ground truth", GroundTruth, require)
    arrays = {f.name: d.get(f.name) for f in fields(GroundTruth)}
    if arrays["valid"] is None:
        arrays["valid"] = np.ones(len(d["rotvecs"]), bool)
    return GroundTruth(**arrays)


def save_ground_truth(project_or_root, truth: GroundTruth) -> None:
    """Write ``gt.npz`` atomically; fields that are None are left out."""
    arrays = {f.name: getattr(truth, f.name) for f in fields(GroundTruth)}
    save_npz(_project(project_or_root).ground_truth_path, **{k: v for k, v in arrays.items() if v is not None})


# ---- holdout.npz and its images --------------------------------------------------------------
def has_holdout(project_or_root) -> bool:
    """Whether the project (or the project in this folder) has a hold-out sequence."""
    return _project(project_or_root).holdout_path.is_file()


def load_holdout(project_or_root, require: tuple[str, ...] = ()) -> HoldoutSequence:
    """The hold-out sequence's poses and camera; raises :class:`GroundTruthError` when the file is
    missing, lacks rotvecs, transl or an array named in ``require`` (field names of
    :class:`HoldoutSequence`), or stores part of a camera."""
    path = _project(project_or_root).holdout_path
    d = _load(path, "hold-out sequence", HoldoutSequence, tuple(k for k in require if k != "camera"))
    camera = None
    if "K" in d or "camera" in require:
        lacking = [k for k in _CAMERA_KEYS if k not in d]
        if lacking:
            raise GroundTruthError(f"damaged hold-out sequence {path}: no {lacking[0]!r} array of its camera; "
                                   "remake the capture with 'morf synth'")
        K = d["K"]
        camera = PinholeCamera(float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2]), int(d["width"]),
                               int(d["height"]), d["R"].astype(float), d["t"].astype(float))
    arrays = {f.name: d.get(f.name) for f in fields(HoldoutSequence) if f.name != "camera"}
    return HoldoutSequence(**arrays, camera=camera)


def save_holdout(project_or_root, holdout: HoldoutSequence) -> None:
    """Write ``holdout.npz`` atomically (after its images); fields that are None are left out."""
    arrays = {f.name: getattr(holdout, f.name) for f in fields(HoldoutSequence) if f.name != "camera"}
    arrays = {k: v for k, v in arrays.items() if v is not None}
    cam = holdout.camera
    if cam is not None:
        arrays.update(K=cam.K, R=cam.R, t=cam.t, width=np.int64(cam.width), height=np.int64(cam.height))
    save_npz(_project(project_or_root).holdout_path, **arrays)


def write_holdout_images(project_or_root, j: int, rgb: np.ndarray, mask: np.ndarray) -> None:
    """Store hold-out image ``j``: (H, W, 3) uint8 RGB and its (H, W) bool person mask."""
    project = _project(project_or_root)
    write_image(project.holdout_frame_path(j), rgb)
    write_image(project.holdout_mask_path(j), np.asarray(mask, bool).astype(np.uint8) * 255)


def read_holdout_frame(project_or_root, j: int) -> np.ndarray:
    """(H, W, 3) uint8 RGB hold-out image ``j``."""
    return read_image(_project(project_or_root).holdout_frame_path(j))


def read_holdout_mask(project_or_root, j: int) -> np.ndarray:
    """(H, W) uint8 hold-out mask ``j`` as stored, 0 or 255."""
    return read_image(_project(project_or_root).holdout_mask_path(j), grayscale=True)
