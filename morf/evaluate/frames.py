"""A target's frames as a :class:`FrameSet` seen through a run's working camera at the evaluation
resolution: the capture cropped to the run's square and resized, and the body rasterized there.

The working camera a run trained with (``TrainedAvatar.camera``) is a square crop of the capture
camera (:func:`morf.train.data.crop_camera`); scaling it keeps the crop and changes only the
pixel count, and the renderer is fully convolutional, so a run renders at any side that is a
multiple of its renderer's ``multiple``.
"""

from __future__ import annotations

import numpy as np

from morf.camera import PinholeCamera
from morf.errors import InputError
from morf.synth.ground_truth import load_holdout
from morf.train.data import BodyFitArrays, build_holdout_frames, crop_image, crop_of, holdout_poses, rasterize_frames
from morf.train.frames import FrameSet, pack_uv


def eval_side(working: PinholeCamera, capture: PinholeCamera, resolution: int | str | None, multiple: int) -> int:
    """The square side a run is evaluated at.

    ``resolution``: None (the run's training side), "native" (the crop's size in capture pixels,
    rounded to the renderer's multiple) or a side in pixels (must be a multiple of it).
    """
    if resolution is None:
        return working.width
    if resolution == "native":
        side = crop_of(capture, working)[2]
        return max(multiple, int(round(side / multiple)) * multiple)
    r = int(resolution)
    if r < 1 or r % multiple:
        raise InputError(f"--resolution {r} must be a positive multiple of {multiple} (the renderer's size multiple)")
    return r


def scaled_camera(working: PinholeCamera, side: int) -> PinholeCamera:
    """The working camera for the same square crop rendered at ``side`` pixels."""
    return working if side == working.width else working.scaled(side / working.width)


def capture_frames(project, model, fits: BodyFitArrays, ids, working: PinholeCamera,
                   offsets: np.ndarray | None = None) -> FrameSet:
    """Project frames ``ids`` cropped to ``working``'s square, posed by ``fits`` and rasterized
    (the body dressed by clothing ``offsets`` (V,) when given)."""
    ids = list(ids)
    x0, y0, side = crop_of(project.camera(), working)
    R = working.width
    images, masks, uvs, uv_masks, facings = [], [], [], [], []
    rot, tr = fits.rotvecs[ids], fits.transl[ids]
    done = 0
    for uv, uvm, fac in rasterize_frames(model, rot, tr, fits.shape, working, offsets=offsets):
        for i in ids[done:done + len(uv)]:
            images.append(crop_image(project.load_frame(i), x0, y0, side, R))
            masks.append(crop_image(project.load_mask(i).astype(np.uint8) * 255, x0, y0, side, R) > 127)
        done += len(uv)
        uvs.append(pack_uv(uv))
        uv_masks.append(uvm)
        facings.append(fac)
    return FrameSet(np.stack(images), np.stack(masks), np.concatenate(uvs), np.concatenate(uv_masks),
                    np.concatenate(facings), rot.astype(np.float32), np.asarray(ids, np.int64))


def target_frames(project, model, target, fits: BodyFitArrays | None, shape: np.ndarray,
                  working: PinholeCamera, offsets: np.ndarray | None = None) -> FrameSet:
    """The FrameSet of an :class:`~morf.evaluate.targets.EvalTarget` through ``working``, the body
    dressed by the clothing ``offsets`` the run trained with (None: naked), as the player draws it."""
    if target.kind == "capture":
        return capture_frames(project, model, fits, target.frame_ids, working, offsets)
    fs = build_holdout_frames(project, model, working, shape, fits, offsets)  # moved into the fitted frame
    if fs is None:
        raise InputError(f"{project.root} has no hold-out sequence")
    return fs


def target_poses(project, target, fits: BodyFitArrays | None, shape: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The poses :func:`target_frames` rasterizes: (rotvecs (N, J, 3), transl (N, 3), shape (1, S))."""
    if target.kind == "capture":
        ids = list(target.frame_ids)
        return fits.rotvecs[ids], fits.transl[ids], np.asarray(fits.shape).reshape(1, -1)
    rot, tr = holdout_poses(project, load_holdout(project), fits)
    return rot, tr, np.asarray(shape).reshape(1, -1)
