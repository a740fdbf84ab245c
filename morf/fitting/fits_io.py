"""Body fits on disk (``CaptureProject.fits_path``, PROJECT/fits/fits.npz): the one reader and
writer of that file; later stages call :func:`load_fits`. Torch-free (the player reads fits through
``morf.motion.formats``): import nothing here that brings torch."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.errors import ProjectError
from morf.io import load_npz, save_npz
from morf.records import length_of

CHECKPOINT_FILE = "checkpoint.npz"


@dataclass(frozen=True)
class BodyFits:
    """Body fits of every frame of a capture.

    Fields:
        rotvecs: (N, J, 3) float32 axis-angle per bone (Anny "local-ref"; bone 0 = root).
        transl: (N, 3) float32 root translation, metres.
        shape: (1, S) shared or (N, S) per-frame phenotype values in [0, 1].
        keypoint_residual_px: (N,) float32 mean distance of fitted to detected keypoints.
        keypoint_worst_px: (N,) float32 mean of the 3 largest of those distances.
        silhouette_iou: (N,) float32 IoU of body silhouette and person mask (NaN without masks).
        projected_keypoints: (N, 23, 2) float32 fitted keypoints in pixels.
        config: the FitConfig as a dict.
        silhouette_iou_body: (N,) float32 IoU of the body alone (without offsets) and the mask.
        offsets: (V,) float32 clothing offsets per model vertex, metres along the outward normals
            of the shaped rest mesh, or None. The fitted surface of frame i is the body skinned
            from ``rest_vertices + offsets[:, None] * rest_normals``:
            ``morf.fitting.offsets.dressed_vertices(model, model(pose, shape), shape, offsets)``.
        twist_deg: (N,) float32 pelvis-shoulder twist of the fitted body, degrees
            (``morf.fitting.twist``), or None in fits written before it was measured.
        label_swapped: (N,) bool, frames whose detected keypoints were fitted with left and right
            exchanged (``morf.fitting.heading``: a back view the detector labelled as a front
            view), or None when no frame was.
        landmark_residual_px: (N, 3) float32 mean distance of the fitted face anchors, left hand
            and right hand to their landmarks after the head-and-hands refinement, before its
            changes are smoothed over video neighbours (``morf.fitting.landmark_refinement``;
            NaN where a group had too little evidence), or
            None when the fit had no landmarks.
    """

    rotvecs: np.ndarray
    transl: np.ndarray
    shape: np.ndarray
    keypoint_residual_px: np.ndarray
    keypoint_worst_px: np.ndarray
    silhouette_iou: np.ndarray
    projected_keypoints: np.ndarray
    config: dict
    silhouette_iou_body: np.ndarray | None = None
    offsets: np.ndarray | None = None
    twist_deg: np.ndarray | None = None
    label_swapped: np.ndarray | None = None
    landmark_residual_px: np.ndarray | None = None

    num_frames = length_of("rotvecs")

    def shape_of(self, i: int) -> np.ndarray:
        """(1, S) the shape of frame ``i``."""
        return self.shape[:1] if self.shape.shape[0] == 1 else self.shape[i:i + 1]


# The arrays that mark an .npz as a fits file: written by :func:`save_fits` beside rotvecs / transl
# and held by no other motion .npz (:func:`morf.motion.formats.npz_motion_kind` tells kinds by them).
FITS_ONLY_KEYS = ("keypoint_residual_px", "projected_keypoints")


def save_fits(path: str | Path, fits: BodyFits) -> None:
    """Atomically write ``fits`` (a project's is ``project.fits_path``)."""
    extra = {k: getattr(fits, k).astype(np.float32) for k in ("silhouette_iou_body", "offsets", "twist_deg",
                                                              "landmark_residual_px")
             if getattr(fits, k) is not None}
    if fits.label_swapped is not None:
        extra["label_swapped"] = np.asarray(fits.label_swapped, bool)
    save_npz(path, rotvecs=fits.rotvecs.astype(np.float32), transl=fits.transl.astype(np.float32),
             shape=fits.shape.astype(np.float32), keypoint_residual_px=fits.keypoint_residual_px.astype(np.float32),
             keypoint_worst_px=fits.keypoint_worst_px.astype(np.float32),
             silhouette_iou=fits.silhouette_iou.astype(np.float32),
             projected_keypoints=fits.projected_keypoints.astype(np.float32),
             config=np.array(json.dumps(fits.config)), **extra)


def read_fits(path: str | Path) -> BodyFits:
    """The fits file at ``path``, checked for missing fields and inconsistent shapes."""
    d = load_npz(path)
    try:
        fits = BodyFits(rotvecs=d["rotvecs"], transl=d["transl"], shape=d["shape"],
                        keypoint_residual_px=d["keypoint_residual_px"], keypoint_worst_px=d["keypoint_worst_px"],
                        silhouette_iou=d["silhouette_iou"],
                        projected_keypoints=d["projected_keypoints"], config=json.loads(str(d["config"])),
                        silhouette_iou_body=d.get("silhouette_iou_body"), offsets=d.get("offsets"),
                        twist_deg=d.get("twist_deg"), label_swapped=d.get("label_swapped"),
                        landmark_residual_px=d.get("landmark_residual_px"))
    except (KeyError, ValueError) as e:
        raise ProjectError(f"damaged fits file {path}: {e}") from None
    N = fits.rotvecs.shape[0]
    if fits.rotvecs.ndim != 3 or fits.transl.shape != (N, 3) or fits.shape.shape[0] not in (1, N):
        raise ProjectError(f"damaged fits file {path}: inconsistent shapes")
    if fits.landmark_residual_px is not None and fits.landmark_residual_px.shape != (N, 3):
        raise ProjectError(f"damaged fits file {path}: landmark_residual_px must be ({N}, 3)")
    if fits.label_swapped is not None and fits.label_swapped.shape != (N,):
        raise ProjectError(f"damaged fits file {path}: label_swapped must be ({N},)")
    if fits.offsets is not None and fits.offsets.ndim != 1:
        raise ProjectError(f"damaged fits file {path}: offsets must be (V,)")
    return fits


def load_fits(project) -> BodyFits:
    """The body fits of a :class:`~morf.capture.project.CaptureProject` (run ``morf fit`` first)."""
    path = project.fits_path
    if not path.is_file():
        raise ProjectError(f"{project.root} has no body fits yet; run 'morf fit {project.root}'")
    fits = read_fits(path)
    if fits.num_frames != project.num_frames:
        raise ProjectError(f"fits cover {fits.num_frames} frames, project has {project.num_frames}; run 'morf fit --restart'")
    return fits


def save_checkpoint(path: Path, *, stage: int, rotvecs: np.ndarray, transl: np.ndarray, shape: np.ndarray,
                    config: dict, offsets: np.ndarray | None = None, gaps: np.ndarray | None = None,
                    spacing: str = "", swapped: np.ndarray | None = None) -> None:
    """Parameters after ``stage`` completed stages (resume point); ``offsets``: (Vp,) proxy offsets;
    ``gaps`` (N-1,) and ``spacing``: the frame spacing the fit found (``morf.fitting.frame_spacing``),
    kept so that a resumed fit smooths exactly as the one it continues; ``swapped`` (N,) the frames
    whose left/right labels the first stage exchanged (``morf.fitting.heading``)."""
    off = np.zeros(0, np.float32) if offsets is None else offsets.astype(np.float32)
    extra = {} if gaps is None else {"gaps": np.asarray(gaps, np.float64), "spacing": np.array(spacing)}
    if swapped is not None:
        extra["swapped"] = np.asarray(swapped, bool)
    save_npz(path, stage=np.array(stage), rotvecs=rotvecs.astype(np.float32), transl=transl.astype(np.float32),
             shape=shape.astype(np.float32), offsets=off, config=np.array(json.dumps(config, sort_keys=True)), **extra)


def read_checkpoint(path: Path) -> dict | None:
    """The checkpoint as a dict (stage, rotvecs, transl, shape, offsets, config, gaps, spacing,
    swapped; gaps and swapped None in checkpoints without them) or None if unreadable."""
    if not path.is_file():
        return None
    try:
        d = load_npz(path)
        return {"stage": int(d["stage"]), "rotvecs": d["rotvecs"], "transl": d["transl"], "shape": d["shape"],
                "offsets": d.get("offsets", np.zeros(0, np.float32)), "config": json.loads(str(d["config"])),
                "gaps": d.get("gaps"), "spacing": str(d["spacing"]) if "spacing" in d else "",
                "swapped": d.get("swapped")}
    except (ProjectError, KeyError, ValueError):
        return None
