"""A capture's body fits (``PROJECT/fits/fits.npz``) as a motion: one avatar moves as the person
of another capture did.

Fits are Anny poses already, so no joint mapping is needed; what changes is the world. Fits live in
their capture's camera world (Y down for a video, Z up for a synthetic capture), so the motion
is turned upright (the median up axis of the fitted root onto +Z), turned to face -Y and started
at x = y = 0 like every clip; horizontal translation is scaled by the leg-length ratio of the
two bodies and the feet are put on the floor for the target body. The frame rate is the capture
project's when the file sits in one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from morf.capture.project import CaptureProject
from morf.errors import InputError, MorfError
from morf.motion.anny_rest import target_rest
from morf.motion.checks import MAX_PHENOTYPE, check_fps, check_range, check_rotvecs, check_translations
from morf.motion.clip import MotionClip, at_uniform_times, resample
from morf.motion.convert import RetargetConfig
from morf.motion.ground import place_on_ground
from morf.motion.retargeting import heading_turn
from morf.motion.so3 import matrix_to_rotvec, rotvec_to_matrix, swing

FITS_DEFAULT_FPS = 30.0  # fits outside a capture project with a known frame rate


def project_timing(path: Path) -> tuple[float | None, np.ndarray | None]:
    """(frame rate, per-frame times in seconds) of the capture project whose fits folder holds
    ``path`` (its ``fits_path``); (None, None) outside a project, times None when it knows none."""
    root = CaptureProject.fits_owner(path.resolve())
    if root is None or not CaptureProject.is_project(root):
        return None, None
    try:
        project = CaptureProject.open(root)
        fps, times = project.fps, project.frame_times()
    except MorfError:
        return None, None
    return (float(fps) if fps and fps > 0 else None), times


def project_shape(project) -> torch.Tensor | None:
    """(1, S) float32: the mean fitted phenotype of a capture project, or None without usable fits."""
    from morf.fitting.fits_io import load_fits

    try:
        fits = load_fits(project)
    except MorfError:
        return None
    return torch.as_tensor(fits.shape.mean(axis=0, keepdims=True), dtype=torch.float32)


def upright_motion(rotvecs: np.ndarray, transl: np.ndarray, face_forward: bool = True,
            center: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Turn a motion so its root's median up axis is +Z; then (if asked) turn it about Z to face
    -Y on frame 0 and shift frame 0 to x = y = 0.

    Args:
        rotvecs: (T, J, 3) Anny local-ref axis-angle; transl: (T, 3) root translation.
    Returns:
        rotvecs (T, J, 3) (only the root changes) and transl (T, 3), float64.
    """
    R0 = rotvec_to_matrix(rotvecs[:, 0])
    up = np.median(R0[:, :, 2], axis=0)  # Anny's rest body is Z up
    W = swing(up, np.array([0.0, 0.0, 1.0]))
    if face_forward:
        W = heading_turn(W @ R0[0]) @ W
    out = np.asarray(rotvecs, np.float64).copy()
    out[:, 0] = matrix_to_rotvec(W @ R0)
    t = np.asarray(transl, np.float64) @ W.T  # the root's head is at transl, so rotate it whole
    if center:
        t[:, :2] -= t[0, :2]
    return out, t


def clip_from_fits(path: str | Path, model, shape: torch.Tensor | None = None, fps: float | None = None,
                   config: RetargetConfig = RetargetConfig()) -> MotionClip:
    """The fits file at ``path`` as a clip for ``model`` (Anny) with target phenotype ``shape`` (1, 6).

    ``fps`` is the rate when the file is not in a capture project with a known one (default 30).
    ``config`` as for :func:`~morf.motion.convert.retarget` (output rate, facing, ground).
    Raises:
        InputError / ProjectError: not a readable fits file, or fits of another body model.
    """
    from morf.fitting.fits_io import read_fits

    path = Path(path)
    fits = read_fits(path)
    J = len(model.bone_names)
    if fits.rotvecs.shape[1:] != (J, 3) or fits.num_frames == 0:
        raise InputError(f"{path}: fits have rotvecs {fits.rotvecs.shape}; expected (N, {J}, 3)")
    check_rotvecs(fits.rotvecs, str(path), "'rotvecs'")
    check_translations(fits.transl, str(path), "'transl'")
    check_range(fits.shape, str(path), "'shape'", MAX_PHENOTYPE, "", "body shape value")
    project_rate, times = project_timing(path)
    rate = check_fps(project_rate or fps or FITS_DEFAULT_FPS, str(path))
    rotvecs, transl = upright_motion(fits.rotvecs, fits.transl, config.face_forward, config.center_start)
    if times is not None and len(times) == len(rotvecs) > 1 and (np.diff(times) > 0).all():
        uniform = times[0] + np.arange(len(times)) / rate
        if np.abs(times - uniform).max() > 0.25 / rate:  # a variable frame rate clip: play it at its real pace
            rotvecs, transl = at_uniform_times(rotvecs, transl, times, rate)
    source_shape = torch.as_tensor(np.asarray(fits.shape_of(0), np.float32))
    if source_shape.shape[1] != model.default_shape().shape[1]:
        raise InputError(f"{path}: fits shape has {source_shape.shape[1]} values; the body model takes "
                         f"{model.default_shape().shape[1]}")
    scale = target_rest(model, shape).leg_length / target_rest(model, source_shape).leg_length
    transl[:, :2] *= scale
    owner = CaptureProject.fits_owner(path)  # the capture's folder names the clip
    name = owner.name if owner is not None else path.stem
    clip = MotionClip(rotvecs.astype(np.float32), transl.astype(np.float32), rate, name,
                      f"fits:{path} ({fits.num_frames} frames, scale {scale:.3f})")
    if config.fps is not None and abs(config.fps - rate) > 1e-6:
        clip = resample(clip, config.fps)
    if config.keep_feet_on_ground:
        clip = place_on_ground(clip, model, shape, None, config.ground)
    return clip
