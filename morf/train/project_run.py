"""Train an avatar for a capture project: the function behind ``morf train`` and the studio.

Resolves the run folder, prepares (or loads the cached) training frames, the spectral texture,
the perceptual loss and the inpainting views, then calls :func:`morf.train.loop.train_avatar`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import torch

from morf.errors import InputError
from morf.pipeline.control import Progress, StageControl
from morf.train.config import TrainConfig
from morf.train.holdout import holdout_note
from morf.train.frame_scores import FrameScores
from morf.train.inpaint_views import InpaintViews
from morf.train.loop import TrainResult, train_avatar
from morf.io.lock import project_lock
from morf.train.run_dir import RunDir
from morf.train.run_files import restart_run, run_path
from morf.train.trained_avatar import render_batch


def default_run_name(cfg: TrainConfig) -> str:
    return f"{cfg.method}-{cfg.preset}"


def train_project(project, cfg: TrainConfig, name: str | None = None, control: StageControl | None = None,
                  fits_source: str = "auto", vgg: str | None = None, restart: bool = False,
                  model=None) -> TrainResult:
    """Train (or resume) ``PROJECT/runs/<name>``.

    Args:
        project: a CaptureProject; cfg: the resolved config (resuming needs the same config);
        name: run name (default ``<method>-<preset>``); fits_source: auto | fits | ground-truth;
        vgg: VGG-16 weights path (else ``$MORF_VGG16_WEIGHTS``; none: feature matching);
        restart: delete an existing run of that name first; model: a loaded body model (optional).
    The run's lock (``morf.io.lock``) is held throughout: a second writer of the run is refused.
    """
    if cfg.method == "rgb":  # the no-learning floor: no network, seconds
        from morf.train.floor import train_floor

        return train_floor(project, cfg, name, fits_source, model, control, restart=restart)
    control = control or StageControl()
    run = RunDir(run_path(project, name or default_run_name(cfg)))
    with project_lock(project.root, f"run-{run.root.name}"):
        return _train_run(project, run, cfg, control, fits_source, vgg, restart, model)


def _train_run(project, run: RunDir, cfg: TrainConfig, control: StageControl, fits_source: str, vgg: str | None,
               restart: bool, model) -> TrainResult:
    """:func:`train_project` for one run folder, with its lock held."""
    from morf.avatar.spectral import body_uv_atlas
    from morf.avatar.vgg import PerceptualLoss, load_vgg16, resolve_vgg_path
    from morf.body import load_body_model
    from morf.train.data import build_frames
    from morf.train.pseudo_views import make_pseudo_views

    if restart:
        restart_run(run.root)
    if run.config_path.is_file() and run.load_config() != cfg:
        raise InputError(f"run {run.root.name!r} exists with a different configuration; resume it with the same "
                         "options, or pass --restart or another --name")
    control.report(Progress("train", 0, cfg.steps, "loading body model"))
    model = model or load_body_model("anny")
    pf = build_frames(project, model, cfg.resolution, fits_source, control, holdout=cfg.holdout, dressed=cfg.dressed,
                      holdout_by=cfg.holdout_by)
    zoom, zoom_pf, centres = None, None, None
    if cfg.zoom_resolution:
        zoom_pf = build_frames(project, model, cfg.zoom_resolution, fits_source, control, holdout=cfg.holdout,
                               dressed=cfg.dressed, holdout_by=cfg.holdout_by)
        zoom = zoom_pf.frames
    notes = [f"fits: {pf.fits.source}; frames cache: {pf.cache_path}"]
    if pf.offsets is not None:
        notes.append(f"body dressed by the fit's clothing offsets (mean {1000 * float(pf.offsets.mean()):.1f} mm, "
                     f"max {1000 * float(pf.offsets.max()):.1f} mm)")
    if zoom is not None:
        notes.append(f"every other step: {cfg.crop or cfg.resolution} px crops of the frames at {cfg.zoom_resolution} px")
    if cfg.detail_every:
        from morf.train.detail import detail_centres, detail_points

        fits = pf.fits
        ids = zoom.frame_ids
        centres = detail_centres(detail_points(model, fits.rotvecs[ids], fits.transl[ids], fits.shape),
                                 zoom_pf.camera)
        notes.append(f"every {cfg.detail_every}th step: those crops centred on the head (half) or a hand")
    if cfg.holdout:
        notes.append(holdout_note(cfg.holdout, cfg.holdout_by))
    atlas = body_uv_atlas(model, cfg.texture_size, cfg.texture_size)
    fs = pf.frames
    tex, source, how = _initial_texture(cfg, model, fs, zoom, atlas, notes)
    vgg_path = resolve_vgg_path(vgg)
    perceptual = PerceptualLoss(load_vgg16(vgg_path)) if vgg_path is not None else None
    if vgg_path is not None:
        notes.append(f"VGG-16 weights: {vgg_path}")
    mid = fs.num_frames // 2
    centre = pf.fits.transl[fs.frame_ids].mean(0)

    def views():
        return make_pseudo_views(model, pf.fits.shape, pf.camera, fs.rotvecs[mid], centre, cfg.inpaint_views,
                                 pf.offsets)

    result = train_avatar(fs, run.root, cfg, tex, control, perceptual, InpaintViews(atlas.covered, views),
                          shape=torch.from_numpy(pf.fits.shape), camera=pf.camera, notes=notes, zoom_frames=zoom,
                          detail_centres=centres)
    if cfg.view_colours and source is not None:
        from morf.train.view_colours import attach_view_colours

        control.report(Progress("train", cfg.steps, cfg.steps, f"projecting {cfg.view_colours} view colours"))
        attach_view_colours(run, source, atlas.covered, cfg, how, model, pf.fits.shape, pf.camera.R)
    return result


def _initial_texture(cfg: TrainConfig, model, fs, zoom, atlas, notes: list[str]):
    """(the initial (C, S, S) texture, the FrameSet its colour channels were projected from, the
    projection's settings): with colour channels (``renderer.rgb_skip``) channels 0-2 are the frames
    projected and the rest spectral; without them all spectral (then None, None)."""
    from morf.avatar.spectral import spectral_texture

    if not cfg.renderer.rgb_skip:
        return torch.from_numpy(spectral_texture(model, cfg.texture_channels, cfg.texture_size, cfg.texture_size,
                                                 cfg.texture_dilate)), None, None
    from morf.train.colour_align import aligned_floor_texture
    from morf.train.texel_splat import Projection

    source = zoom if cfg.colour_from_zoom else fs
    # the floor's colours (step 0 = floor), unless weighted towards the frames that face a texel
    # or aligned to one another first (0 passes: exactly the floor's projection)
    how = Projection(cfg.colour_facing_power, cfg.colour_bilinear, cfg.colour_prior_count, cfg.colour_edge_inset)
    how = replace(how, back_projections=_back_projections(cfg, source, how, notes))
    projected, _, aligned = aligned_floor_texture(source, atlas.covered, cfg.colour_align_passes,
                                                  cfg.texture_dilate, how=how)
    spec = spectral_texture(model, cfg.texture_channels - 3, cfg.texture_size, cfg.texture_size, cfg.texture_dilate)
    tex = torch.from_numpy(np.concatenate([projected[:3], spec], axis=0))
    spread = "".join([", each pixel shared among four texels" if how.bilinear else "",
                      f", texels few pixels saw drawn to their neighbourhood ({how.prior_count:g} pixels)"
                      if how.prior_count else "",
                      f", then {how.back_projections} back-projection pass(es)" if how.back_projections else ""])
    notes.append(f"texture channels 0-2: the training frames at {source.resolution} px projected (colour{spread}); "
                 "the renderer adds a residual")
    if cfg.colour_align_passes:
        notes.append(f"texture channels 0-2: {aligned.describe()}")
    return tex, source, how


def backdrop_colour(frames) -> torch.Tensor:
    """(3,) the capture's backdrop: the median colour outside the person masks of about 16
    frames spread over ``frames`` (what :func:`evaluate_frames` composites over)."""
    from morf.avatar.metrics import background_colour

    sample = frames.batch(list(range(0, frames.num_frames, max(1, frames.num_frames // 16))))
    return background_colour(sample.image, sample.mask)


def evaluate_frames(avatar, frames, background: str = "capture", ordered: bool = True) -> FrameScores:
    """Render every frame of a FrameSet with a TrainedAvatar and score it against the frames.

    Both the render and the frame are composited over one flat colour, as the player composites
    (``rgb + (1 - mask) * colour``): ``background="capture"`` uses the median colour outside the
    person masks of the frames (the capture's own backdrop), ``"black"`` compares on black.
    Returns PSNR / SSIM over the whole image and over the person only (``*_person``, the ground
    truth mask), ``temporal`` flicker (frames in order), the background colour and the frame count
    (:class:`~morf.train.frame_scores.FrameScores`). ``ordered=False`` (a photo set's unordered
    views): no flicker (NaN), since neighbouring frames are unrelated photos.
    """
    from morf.avatar.metrics import composite_over, psnr, ssim, summarize, temporal_flicker

    if background not in ("capture", "black"):
        raise ValueError("background must be 'capture' or 'black'")
    colour = backdrop_colour(frames) if background == "capture" else torch.zeros(3)
    preds, gts, masks = [], [], []
    p_all, p_person, s_all, s_person = [], [], [], []
    for i in range(frames.num_frames):
        b = frames.batch([i])
        rgb, alpha = render_batch(avatar, b)
        pred = composite_over(rgb, alpha, colour)
        gt = composite_over(b.image * b.mask, b.mask, colour)
        p_all.append(psnr(pred, gt)); s_all.append(ssim(pred, gt))
        p_person.append(psnr(pred, gt, b.mask)); s_person.append(ssim(pred, gt, b.mask))
        preds.append(pred[0]); gts.append(gt[0]); masks.append(b.mask[0])
    return FrameScores(summarize(p_all), summarize(s_all), summarize(p_person), summarize(s_person),
                       temporal_flicker(torch.stack(preds), torch.stack(gts), torch.stack(masks))
                       if ordered else float("nan"),
                       tuple(round(float(c), 4) for c in colour), frames.num_frames,
                       _warp_flicker(preds, gts, masks) if ordered else None)


def _warp_flicker(preds: list, gts: list, masks: list) -> tuple[float, float] | None:
    """:func:`morf.avatar.warp_flicker.warping_errors` of (3, H, W) tensors (None on images under 32 px)."""
    from morf.avatar.warp_flicker import warping_errors

    if min(gts[0].shape[-2:]) < 32:
        return None
    hwc = [np.stack([t.permute(1, 2, 0).numpy() for t in seq]) for seq in (preds, gts)]
    return warping_errors(hwc[0], hwc[1], np.stack([m[0].numpy() for m in masks]))


def _back_projections(cfg: TrainConfig, source, how, notes: list[str]) -> int:
    """The colour's back-projection passes: ``cfg.colour_back_projections``, or with -1 the count
    :func:`morf.train.back_project.choose_back_projections` finds on ``source`` projected as ``how``
    says (said in ``notes``)."""
    if cfg.colour_back_projections >= 0:
        return cfg.colour_back_projections
    from morf.train.back_project import choose_back_projections

    choice = choose_back_projections(source, cfg.texture_size, 0.3, how)
    notes.append(f"texture channels 0-2: {choice.describe()}")
    return choice.passes
