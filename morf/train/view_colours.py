"""After training: the avatar's colour channels by view (:mod:`morf.avatar.view_colour`), added to
``avatar.pt`` when the run's config asks for them (``view_colours`` > 0)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import torch

from morf.avatar.view_colour import ViewColours, angles_between, spread_anchors, view_orientation
from morf.body.anny_model import reference_rotations
from morf.io import atomic_path
from morf.io.torch_files import load_torch_file


def attach_view_colours(run, frames, covered: np.ndarray, cfg, how, model, shape: np.ndarray, camera_R) -> bool:
    """Project ``cfg.view_colours`` view colours from ``frames`` (the FrameSet the colour channels
    were projected from) into ``run``'s finished avatar.pt, unless it holds them already (a resumed
    or finished run). Texels a view's frames did not see keep the avatar's colour. ``model`` and
    ``shape``: the body the poses turn (its skeleton's root frame); ``camera_R``: the capture
    camera's rotation. Returns whether it wrote them."""
    path = run.avatar_path
    d = load_torch_file(path, what="avatar")
    if d.get("view_colours") is not None:
        return False
    t0 = time.monotonic()
    base = d["texture"][:3].numpy()
    aligned = ""
    if cfg.colour_align_passes:  # the one texture came from aligned frames: the views from the same
        from morf.train.colour_align import MAX_FLOW_SHARE, align_frames

        frames = align_frames(frames, np.ascontiguousarray(base.transpose(1, 2, 0)),
                              MAX_FLOW_SHARE * frames.resolution)[0]
        aligned = ", the frames first aligned to the avatar's colour"
    root_frame = reference_rotations(model, shape)[0]
    views = project_view_colours(frames, covered, base, cfg.view_colours, cfg.view_colour_frames, cfg.texture_dilate,
                                 how, root_frame, camera_R, cfg.view_colour_margin)
    head = ""
    if cfg.head_view_colours:
        views, head = _with_head_colours(views, frames, covered, base, cfg, how, model, shape, camera_R, run)
    d["view_colours"] = views.to_dict()
    with atomic_path(path) as tmp:
        torch.save(d, tmp)
    run.log(f"view colours: {views.count} anchor orientations, each projected from the {views.frames} training "
            f"frames nearest it{aligned}{head} ({time.monotonic() - t0:.1f} s)")
    return True


def _with_head_colours(views, frames, covered, base, cfg, how, model, shape, camera_R, run):
    """``views`` with the head's own colours (:mod:`morf.train.head_colours`), their back-projection
    passes as ``cfg.head_view_colour_passes`` says (-1: chosen on the capture's heads), and the
    words the log adds."""
    from morf.avatar.head_colour import head_share
    from morf.train.head_colours import choose_head_passes, head_chain, head_orientations, project_head_colours

    chain, share = head_chain(model, shape), head_share(model, base.shape[1])
    rot = head_orientations(frames, chain, camera_R)
    passes = cfg.head_view_colour_passes
    if passes < 0:
        choice = choose_head_passes(frames, rot, base.shape[1], cfg.head_view_colour_frames, how, share)
        run.log(f"head colours: {choice.describe()}")
        passes = choice.passes
    head = project_head_colours(frames, covered, base, cfg.head_view_colours, cfg.head_view_colour_frames,
                                cfg.texture_dilate, dataclasses.replace(how, back_projections=passes), chain,
                                camera_R, share, rot)
    words = (f"; the head's {head.count} more by the head's own orientation, each from the {head.frames} frames "
             f"whose head was turned most like it, {passes} back-projection pass(es) ({len(head.texels)} texels)")
    return dataclasses.replace(views, head=head), words


def view_colours_missing(run) -> bool:
    """Whether ``run`` (a RunDir) finished its avatar.pt but not the view colours its config asks
    for (a run stopped in the seconds between the two): running ``morf train`` on it again adds them."""
    if not run.is_done or not run.config_path.is_file():
        return False
    cfg = run.load_config()
    if not cfg.view_colours or not cfg.renderer.rgb_skip or cfg.method == "rgb":
        return False
    return load_torch_file(run.avatar_path, what="avatar").get("view_colours") is None


def project_view_colours(frames, covered: np.ndarray, base: np.ndarray, count: int, per_view: int, dilate: int,
                         how, root_frame: np.ndarray, camera_R: np.ndarray, margin: float = 0.0) -> ViewColours:
    """``count`` view colours from a training FrameSet (its poses turned into orientations by
    :func:`view_orientation` with ``root_frame`` and ``camera_R``):
    each anchor's colour projected (:func:`morf.train.floor_texture.floor_texture` with ``how``) from
    the ``per_view`` frames nearest it by root angle; texels they did not see take ``base`` (3, S, S),
    the avatar's one colour texture (0-1).

    ``margin`` > 0: a view's colour only where its frames saw the texel about as squarely as the
    frames that saw it best (:func:`squareness`): fully where their facing (cos) is at least the
    best's, not at all where it is ``margin`` or more below it, in between linearly; the one
    texture's colour elsewhere. A view's frames see the eyes of a three-quarter view at a slant, and
    the one texture has them from the frames that faced them."""
    from morf.train.floor_texture import floor_texture

    rot = np.stack([view_orientation(camera_R, root_frame, r) for r in frames.rotvecs[:, 0]])
    picked = spread_anchors(rot, count)
    near = np.argsort(angles_between(rot[picked], rot), axis=1, kind="stable")[:, :per_view]
    best = squareness(frames, covered, how, SQUARE_POWER) if margin > 0 else None
    colours = []
    for idx in near:
        idx = np.sort(idx)
        sub = frames.subset(idx)
        tex, seen = floor_texture(sub, covered, dilate, how=how)
        mix = seen.astype(np.float32)
        if best is not None:
            mix = mix * np.clip((squareness(sub, covered, how, how.facing_power) - best + margin) / margin, 0, 1)
        rgb = mix[None] * tex[:3] + (1 - mix[None]) * base
        colours.append(np.clip(np.rint(rgb * 255.0), 0, 255).astype(np.uint8))
    return ViewColours(rot[picked].astype(np.float32), np.stack(colours), per_view,
                       np.asarray(root_frame, np.float64), np.asarray(camera_R, np.float64))


SQUARE_POWER = 8.0  # facing weights that make a texel's mean facing about its best frames'


def squareness(frames, covered: np.ndarray, how, power: float) -> np.ndarray:
    """(S, S) the mean facing (cos, 0-1) of the pixels that project into each texel, weighted by
    facing ** ``power`` (a high power: about the best facing any frame gave it), 0 where none do."""
    import dataclasses

    from morf.train.floor_texture import floor_texture

    faces = dataclasses.replace(frames, images=np.repeat(frames.facing[..., None], 3, axis=-1))
    tex, seen = floor_texture(faces, covered, 0, how=dataclasses.replace(how, facing_power=power, prior_count=0.0))
    return np.where(seen.astype(bool), tex[0], 0.0).astype(np.float32)
