"""From a capture project to a :class:`FrameSet`: body fits -> posed meshes -> rasterized UV maps,
plus the images and masks cropped to a square around the person and resized.

Computed once per project, fits version and resolution, and cached in
``PROJECT/runs/.cache/frames-<key>.npz`` so training never rasterizes.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import torch

from morf.camera import PinholeCamera
from morf.errors import ProjectError
from morf.fitting.fits_io import BodyFits, load_fits
from morf.io import load_npz, save_npz
from morf.pipeline.control import Progress, StageControl
from morf.synth.ground_truth import (GroundTruth, has_ground_truth, has_holdout, load_ground_truth, load_holdout,
                                     read_holdout_frame, read_holdout_mask)
from morf.train.frames import FrameSet, pack_uv
from morf.train.holdout import split_holdout  # noqa: F401  (the split's home; imported from here too)

CACHE_VERSION = 1
FIT_SOURCES = ("auto", "fits", "ground-truth")


@dataclass(frozen=True)
class BodyFitArrays:
    """Body fits of every project frame.

    Fields:
        rotvecs: (N, J, 3) float32; transl: (N, 3) float32; shape: (1, S) float32;
        valid: (N,) bool frames the fit covers; source: "fits" | "ground-truth".
        offsets: (V,) float32 clothing offsets of the fits (``BodyFits.offsets``), or None. A
            dressed avatar (the default, :func:`clothing_offsets`) is rasterized, exported and
            evaluated with them, so loose clothes the naked body lacks get texels.
    """

    rotvecs: np.ndarray
    transl: np.ndarray
    shape: np.ndarray
    valid: np.ndarray
    source: str
    offsets: np.ndarray | None = None


def clothing_offsets(fits: BodyFitArrays, dressed: bool = True) -> np.ndarray | None:
    """(V,) float32 clothing offsets the avatar's body carries: the fits' own when ``dressed`` and
    the fits have them (the ground truth has none), else None (the naked body).

    Training, export and ``morf eval`` all take the offsets through here, so the player draws the
    surface the renderer learned on.
    """
    if not dressed or fits.offsets is None:
        return None
    return np.asarray(fits.offsets, np.float32)


def _mean_shape(shape: np.ndarray) -> np.ndarray:
    """(1, S) float32: per-frame shapes (N, S) become their mean, which the avatar uses."""
    shape = shape.astype(np.float32)
    if shape.ndim == 2 and shape.shape[0] > 1:
        shape = shape.mean(0, keepdims=True)
    return shape.reshape(1, -1)


def _from_fits(fits: BodyFits) -> BodyFitArrays:
    # Every frame has a fit; the frames the filter rejected are left out by the project's decisions.
    return BodyFitArrays(fits.rotvecs.astype(np.float32), fits.transl.astype(np.float32), _mean_shape(fits.shape),
                         np.ones(fits.num_frames, bool), "fits", fits.offsets)


def _from_ground_truth(truth: GroundTruth) -> BodyFitArrays:
    return BodyFitArrays(truth.rotvecs.astype(np.float32), truth.transl.astype(np.float32), _mean_shape(truth.shape),
                         truth.valid.astype(bool), "ground-truth")


def load_body_fits(project, source: str = "auto") -> BodyFitArrays:
    """The project's body fits (:func:`morf.fitting.fits_io.load_fits`), or the synthetic ground
    truth (``ground_truth/gt.npz``) when asked for or when no fits exist on a synthetic project."""
    if source not in FIT_SOURCES:
        raise ProjectError(f"unknown fits source {source!r}; choose one of {', '.join(FIT_SOURCES)}")
    has_fits = project.fits_path.is_file()
    if source == "fits" or (source == "auto" and has_fits):
        if not has_fits:
            raise ProjectError(f"no body fits in {project.root}; run 'morf fit {project.root}' first")
        return _from_fits(load_fits(project))
    if has_ground_truth(project):
        return _from_ground_truth(load_ground_truth(project))
    if source == "ground-truth":
        raise ProjectError(f"{project.root} has no ground truth (only synthetic captures do)")
    raise ProjectError(f"no body fits in {project.root}; run 'morf fit {project.root}' first")


def usable_frame_ids(project, fits: BodyFitArrays) -> list[int]:
    """The project's training frames that have a valid fit, in order."""
    n_fit = len(fits.rotvecs)
    return [i for i in project.training_frames() if i < n_fit and fits.valid[i]]


def published_test_frames(project) -> set[int]:
    """Frames an imported dataset labels "test" in its published split (``morf dataset ... --split
    all`` keeps one label per frame in the manifest); empty unless both "train" and "test" occur.
    Training never uses them, so ``morf eval`` scores the published split honestly."""
    labels = (project.manifest.get("dataset") or {}).get("splits")
    if not isinstance(labels, list) or len(labels) != project.num_frames or not {"train", "test"} <= set(labels):
        return set()
    return {i for i, label in enumerate(labels) if label == "test"}


def person_square(masks: list[np.ndarray], margin: float = 0.08) -> tuple[float, float, float]:
    """(x0, y0, side) of a square holding every mask's person, with a margin (may leave the image)."""
    xs0, ys0, xs1, ys1 = [], [], [], []
    for m in masks:
        ys, xs = np.nonzero(m)
        if len(xs):
            xs0.append(xs.min()); xs1.append(xs.max() + 1); ys0.append(ys.min()); ys1.append(ys.max() + 1)
    if not xs0:
        raise ProjectError("no person pixels in any training mask")
    x0, x1, y0, y1 = min(xs0), max(xs1), min(ys0), max(ys1)
    side = max(x1 - x0, y1 - y0) * (1 + 2 * margin)
    return (x0 + x1) / 2 - side / 2, (y0 + y1) / 2 - side / 2, side


def crop_camera(cam: PinholeCamera, x0: float, y0: float, side: float, resolution: int) -> PinholeCamera:
    """The camera of the square crop [x0, x0+side] x [y0, y0+side] resized to ``resolution``."""
    s = resolution / side
    return PinholeCamera(cam.fx * s, cam.fy * s, (cam.cx - x0) * s, (cam.cy - y0) * s, resolution, resolution,
                         cam.R, cam.t)


def crop_image(img: np.ndarray, x0: float, y0: float, side: float, resolution: int) -> np.ndarray:
    """Crop (zero padding outside the image) and resize with area averaging."""
    xi, yi, si = int(round(x0)), int(round(y0)), int(round(side))
    H, W = img.shape[:2]
    pad = max(0, -xi, -yi, xi + si - W, yi + si - H)
    if pad:
        img = cv2.copyMakeBorder(img, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    crop = img[yi + pad:yi + pad + si, xi + pad:xi + pad + si]
    interp = cv2.INTER_AREA if si > resolution else cv2.INTER_LINEAR
    return cv2.resize(crop, (resolution, resolution), interpolation=interp)


def facing_map(verts: np.ndarray, faces: np.ndarray, face_id: np.ndarray, cam: PinholeCamera) -> np.ndarray:
    """(H, W) uint8 |cos| between each visible face's normal and its view ray, times 255."""
    tri = verts[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-12
    ray = tri.mean(1) - cam.position[None]
    ray /= np.linalg.norm(ray, axis=1, keepdims=True) + 1e-12
    cos = np.abs((n * ray).sum(1))
    out = np.zeros(face_id.shape, np.uint8)
    ok = face_id >= 0
    out[ok] = np.round(cos[face_id[ok]] * 255).astype(np.uint8)
    return out


def posed_render_vertices(model, rotvecs: np.ndarray, transl: np.ndarray, shape: np.ndarray,
                          offsets: np.ndarray | None = None) -> np.ndarray:
    """(B, Vr, 3) posed render-mesh vertices; with clothing ``offsets`` (V,) those of the dressed
    body (the rest vertices moved along the rest normals, then skinned:
    :func:`morf.fitting.offsets.dressed_vertices`)."""
    from morf.body import BodyPose
    from morf.body.render_mesh import render_mesh_for
    from morf.fitting.offsets import dressed_vertices

    with torch.no_grad():
        shape_t = torch.from_numpy(np.asarray(shape, np.float32))
        out = model(BodyPose(torch.from_numpy(rotvecs).float(), torch.from_numpy(transl).float()), shape_t)
        verts = dressed_vertices(model, out, shape_t, None if offsets is None else torch.from_numpy(offsets))
        return render_mesh_for(model).gather(verts).numpy()


def rasterize_frames(model, rotvecs, transl, shape, camera: PinholeCamera, chunk: int = 16,
                     offsets: np.ndarray | None = None):
    """Yield (uv (B, H, W, 2) float32, uv_mask (B, H, W) bool, facing (B, H, W) uint8) per chunk,
    of the body dressed by clothing ``offsets`` (V,) when given (:func:`posed_render_vertices`)."""
    from morf.body.render_mesh import render_mesh_for
    from morf.raster import rasterize_uv_batch

    rm = render_mesh_for(model)
    for s in range(0, len(rotvecs), chunk):
        verts = posed_render_vertices(model, rotvecs[s:s + chunk], transl[s:s + chunk], shape, offsets)
        r = rasterize_uv_batch(verts, rm, camera)
        facing = np.stack([facing_map(v, rm.faces, f, camera) for v, f in zip(verts, r.face_id)])
        yield r.uv, r.mask, facing


@dataclass(frozen=True)
class ProjectFrames:
    """A project's training frames and what was needed to build them.

    Fields:
        frames: the FrameSet; camera: the working camera (square crop, ``resolution`` px);
        fits: the body fits used; cache_path: where the FrameSet is cached;
        offsets: (V,) clothing offsets the body was rasterized with (:func:`clothing_offsets`),
            or None: the naked body.
    """

    frames: FrameSet
    camera: PinholeCamera
    fits: BodyFitArrays
    cache_path: Path
    offsets: np.ndarray | None = None


def build_frames(project, model, resolution: int, fits_source: str = "auto",
                 control: StageControl | None = None, holdout: int = 0, dressed: bool = True,
                 holdout_by: str = "frame") -> ProjectFrames:
    """Load (or build and cache) the training FrameSet of a project at ``resolution``.

    ``holdout`` = K > 0 leaves frames out by the rule ``holdout_by`` (:func:`split_holdout`). ``dressed``:
    rasterize the body with the fits' clothing offsets when they have them (:func:`clothing_offsets`).
    """
    control = control or StageControl()
    fits = load_body_fits(project, fits_source)
    if fits.rotvecs.shape[1] != len(model.bone_names):
        raise ProjectError(f"fits have {fits.rotvecs.shape[1]} bones, the body model {len(model.bone_names)}")
    ids, _ = split_holdout(usable_frame_ids(project, fits), holdout, holdout_by)
    test = published_test_frames(project)
    ids = [i for i in ids if i not in test]
    if not ids:
        raise ProjectError(f"no usable training frames in {project.root} (all dropped or without fits)")
    offsets = clothing_offsets(fits, dressed)
    digest = hashlib.sha1()
    for a in (fits.rotvecs, fits.transl, fits.shape) + (() if offsets is None else (offsets,)):
        digest.update(np.ascontiguousarray(a).tobytes())
    key_src = {"v": CACHE_VERSION, "res": resolution, "ids": ids, "fits": digest.hexdigest(),
               "camera": project.camera().to_dict(), "size": list(project.image_size)}
    key = hashlib.sha1(json.dumps(key_src, sort_keys=True).encode()).hexdigest()[:16]
    path = project.runs_dir / ".cache" / f"frames-{key}.npz"
    if path.is_file():
        try:
            d = load_npz(path)
            cam = PinholeCamera.from_dict(json.loads(str(d["camera"])))
            fs = FrameSet(d["images"], d["masks"], d["uv"], d["uv_mask"], d["facing"], d["rotvecs"], d["frame_ids"])
            return ProjectFrames(fs, cam, fits, path, offsets)
        except (ProjectError, KeyError, ValueError):
            pass  # rebuilt below
    step = max(1, len(ids) // 64)
    x0, y0, side = person_square([project.load_mask(i) for i in ids[::step]])
    cam = crop_camera(project.camera(), x0, y0, side, resolution)
    images, masks, uvs, uv_masks, facings = [], [], [], [], []
    rot, tr = fits.rotvecs[ids], fits.transl[ids]
    done = 0
    for uv, uvm, fac in rasterize_frames(model, rot, tr, fits.shape, cam, offsets=offsets):
        for j in range(len(uv)):
            i = ids[done + j]
            images.append(crop_image(project.load_frame(i), x0, y0, side, resolution))
            m = crop_image(project.load_mask(i).astype(np.uint8) * 255, x0, y0, side, resolution)
            masks.append(m > 127)
        done += len(uv)
        uvs.append(pack_uv(uv))
        uv_masks.append(uvm)
        facings.append(fac)
        control.report(Progress("train", 0, None, f"preparing training frames {done}/{len(ids)}"))
        control.check()
    fs = FrameSet(np.stack(images), np.stack(masks), np.concatenate(uvs), np.concatenate(uv_masks),
                  np.concatenate(facings), rot.astype(np.float32), np.asarray(ids, np.int64))
    save_npz(path, images=fs.images, masks=fs.masks, uv=fs.uv, uv_mask=fs.uv_mask, facing=fs.facing,
             rotvecs=fs.rotvecs, frame_ids=fs.frame_ids, camera=np.array(json.dumps(cam.to_dict())))
    return ProjectFrames(fs, cam, fits, path, offsets)


def crop_of(camera: PinholeCamera, working: PinholeCamera) -> tuple[float, float, float]:
    """(x0, y0, side) of the square crop that turned ``camera`` into ``working`` (see crop_camera)."""
    s = working.fx / camera.fx
    return camera.cx - working.cx / s, camera.cy - working.cy / s, working.width / s


def fitted_frame_offset(project, fits: BodyFitArrays) -> np.ndarray:
    """(3,) mean of fitted minus ground-truth translation over the frames with a valid fit.

    A fitted body lives in its own frame: on the default capture it came out 17 cm farther from
    the camera than the ground truth (std 3 cm), with a larger body, so that it projects onto the
    same pixels. Ground-truth poses rendered with the fitted shape must be moved by this offset,
    or the novel-pose hold-out compares a body that is too large and shifted (zero without a
    ground truth).
    """
    if fits.source != "fits" or not has_ground_truth(project):
        return np.zeros(3, np.float32)
    gt = load_ground_truth(project).transl.astype(np.float32)
    n = min(len(gt), len(fits.transl))
    ok = fits.valid[:n]
    if not ok.any():
        return np.zeros(3, np.float32)
    return (fits.transl[:n][ok] - gt[:n][ok]).mean(0).astype(np.float32)


def holdout_poses(project, hold, fits: BodyFitArrays | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The poses of ``hold``, the project's hold-out sequence (:func:`load_holdout`): rotvecs
    (M, J, 3) and translations (M, 3), moved into the fitted frame of ``fits`` when given
    (:func:`fitted_frame_offset`)."""
    rot, tr = hold.rotvecs.astype(np.float32), hold.transl.astype(np.float32)
    if fits is not None:
        tr = tr + fitted_frame_offset(project, fits)
    return rot, tr


def build_holdout_frames(project, model, working: PinholeCamera, shape: np.ndarray,
                         fits: BodyFitArrays | None = None, offsets: np.ndarray | None = None) -> FrameSet | None:
    """The synthetic hold-out sequence (``ground_truth/holdout``) as a FrameSet at the training crop.

    Poses are the hold-out ground truth; the shape is the avatar's, dressed by clothing
    ``offsets`` (V,) when given (those the avatar was trained with). With ``fits`` (the body fits
    the avatar was trained on) the poses are moved into the fitted frame
    (:func:`fitted_frame_offset`). None when the project has no hold-out sequence.
    """
    if not has_holdout(project):
        return None
    hold = load_holdout(project)
    rot, tr = holdout_poses(project, hold, fits)
    if len(rot) == 0:
        return None
    cam = project.camera() if hold.camera is None else hold.camera
    x0, y0, side = crop_of(cam, working)
    R = working.width
    images, masks, uvs, uvms, facings = [], [], [], [], []
    done = 0
    for uv, uvm, fac in rasterize_frames(model, rot, tr, shape.reshape(1, -1), working, offsets=offsets):
        for j in range(len(uv)):
            i = done + j
            images.append(crop_image(read_holdout_frame(project, i), x0, y0, side, R))
            m = read_holdout_mask(project, i)
            masks.append(crop_image(m, x0, y0, side, R) > 127)
        done += len(uv)
        uvs.append(pack_uv(uv))
        uvms.append(uvm)
        facings.append(fac)
    return FrameSet(np.stack(images), np.stack(masks), np.concatenate(uvs), np.concatenate(uvms),
                    np.concatenate(facings), rot, np.arange(len(rot), dtype=np.int64))
