"""What a capture asks of the avatar's size, measured from the capture itself.

* person height in pixels (from the masks): how many image pixels the texture must feed;
* texture detail: high-frequency energy of the frames inside the person (eroded mask, so the
  silhouette edge does not count), a band-pass RMS of the colour channels in [0, 1] units, measured
  at the scale the person has in the training images (finer detail is lost to the training
  resolution whatever the texture; colour patterns of even luminance count);
* frame count and motion range of the fits (yaw covered, spread of the joint angles);
* silhouette excess: share of the person mask the fitted body does not cover (loose garments,
  hair), which the renderer must draw without the mesh's help.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

# Anny's UV atlas holds about this many atlas units per metre of body surface (area-weighted
# median over faces; quartiles 0.43 / 0.66), so a 1.62 m body spans about 0.82 atlas sides.
ATLAS_UNITS_PER_METRE = 0.507
BODY_HEIGHT_M = 1.62


@dataclass(frozen=True)
class CaptureFeatures:
    """Fields:
        frames: training frames (after the user's and the filter's decisions);
        person_height_px: median person height in the capture's pixels;
        image_height_px: capture image height;
        detail: median band-pass RMS (colour) inside the eroded person mask, fine band (sigma 1 px)
            at the training scale;
        detail_coarse: the same for a coarser band (sigma 3 px), for the report;
        yaw_coverage_deg: degrees of body yaw the fits cover (360 = a full turn), None without fits;
        pose_spread_rad: mean over body bones of the std of their axis-angle, None without fits;
        silhouette_excess: share of mask pixels outside the fitted body's silhouette, None without fits.
    """

    frames: int
    person_height_px: float
    image_height_px: int
    detail: float
    detail_coarse: float
    yaw_coverage_deg: float | None
    pose_spread_rad: float | None
    silhouette_excess: float | None

    def to_dict(self) -> dict:
        import dataclasses

        return dataclasses.asdict(self)


def band_energy(image: np.ndarray, mask: np.ndarray, sigma: float) -> float:
    """RMS of ``image - blur(image, sigma)`` (values in [0, 1]; (H, W) or (H, W, C), RMS over the
    channels too) over ``mask``'s interior, eroded by about 3 sigma so the person's outline does not
    count as texture."""
    k = max(3, int(round(3 * sigma)) * 2 + 1)
    inner = cv2.erode(mask.astype(np.uint8), np.ones((k, k), np.uint8)) > 0
    if inner.sum() < 16:
        return float("nan")
    hp = image - cv2.GaussianBlur(image, (0, 0), sigma)
    return float(np.sqrt(np.mean(hp[inner].astype(np.float64) ** 2)))


def image_features(frames: list[np.ndarray], masks: list[np.ndarray],
                   person_px: float | None = None) -> tuple[float, float, float]:
    """(person height px, fine detail, coarse detail) medians over (H, W, 3) uint8 frames and
    (H, W) bool masks. ``person_px``: the person's height in the training images; a frame where the
    person is taller is shrunk to it (area filter) before its detail is measured."""
    heights, fine, coarse = [], [], []
    for img, m in zip(frames, masks):
        rows = np.flatnonzero(m.any(1))
        if len(rows) == 0:
            continue
        heights.append(rows[-1] - rows[0] + 1)
        rgb = img.astype(np.float32) / 255.0
        scale = min(1.0, person_px / heights[-1]) if person_px else 1.0
        if scale < 1.0:
            rgb = cv2.resize(rgb, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
            m = cv2.resize(m.astype(np.uint8), rgb.shape[1::-1], interpolation=cv2.INTER_NEAREST) > 0
        fine.append(band_energy(rgb, m, 1.0))
        coarse.append(band_energy(rgb, m, 3.0))
    if not heights:
        from morf.errors import ProjectError

        raise ProjectError("no person pixels in the capture's masks")
    return float(np.median(heights)), _median(fine), _median(coarse)


def _median(values: list[float]) -> float:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if len(v) else float("nan")


def motion_features(rotvecs: np.ndarray) -> tuple[float, float]:
    """(yaw coverage in degrees, mean std of the body bones' axis-angle) of (N, J, 3) fits."""
    from morf.body.rotations import axis_angle_to_matrix
    import torch

    R = axis_angle_to_matrix(torch.as_tensor(rotvecs[:, 0], dtype=torch.float64)).numpy()
    fwd = -R[:, :, 1]  # where the body's front (-Y at rest) points
    yaw = np.sort(np.degrees(np.arctan2(fwd[:, 0], -fwd[:, 1])))
    # Covered = the circle minus its largest gap between neighbouring frames' yaws.
    gaps = np.diff(np.concatenate([yaw, yaw[:1] + 360.0])) if len(yaw) > 1 else np.array([360.0])
    spread = float(np.linalg.norm(rotvecs[:, 1:].std(0), axis=-1).mean())
    return float(360.0 - gaps.max()), spread


def silhouette_excess(project, model, fits, ids: list[int]) -> float:
    """Share of person-mask pixels outside the fitted body's rasterized silhouette (a few frames)."""
    from morf.body.render_mesh import render_mesh_for
    from morf.raster import rasterize_uv_batch
    from morf.train.data import posed_render_vertices

    verts = posed_render_vertices(model, fits.rotvecs[ids], fits.transl[ids], fits.shape)
    body = rasterize_uv_batch(verts, render_mesh_for(model), project.camera()).mask
    out, total = 0, 0
    for i, b in zip(ids, body):
        m = project.load_mask(i)
        out += int((m & ~b).sum())
        total += int(m.sum())
    return out / max(total, 1)


def capture_features(project, model=None, samples: int = 12, fits_source: str = "auto",
                     person_px: float | None = None) -> CaptureFeatures:
    """Measure a capture (``samples`` frames spread over the training frames); ``person_px``: the
    person's height in the training images, the scale detail is measured at (None: the capture's)."""
    ids_all = project.training_frames() or list(range(project.num_frames))
    ids = ids_all[:: max(1, len(ids_all) // samples)][:samples]
    frames = [project.load_frame(i) for i in ids]
    masks = [project.load_mask(i) for i in ids]
    height, fine, coarse = image_features(frames, masks, person_px)
    yaw = spread = excess = None
    from morf.errors import ProjectError
    from morf.train.data import load_body_fits

    try:
        fits = load_body_fits(project, fits_source)
    except ProjectError:  # no fits yet: the image features alone decide
        fits = None
    if fits is not None:
        ok = [i for i in ids_all if i < len(fits.rotvecs) and fits.valid[i]]
        if ok:
            yaw, spread = motion_features(fits.rotvecs[ok])
            if model is not None:
                excess = silhouette_excess(project, model, fits, [i for i in ids if i in set(ok)][:6] or ok[:6])
    return CaptureFeatures(len(ids_all), height, project.image_size[1], fine, coarse, yaw, spread, excess)
