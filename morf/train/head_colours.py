"""After training: the head's colour by the head's own orientation (:mod:`morf.avatar.head_colour`),
projected with the view colours when the run's config asks for them (``head_view_colours`` > 0)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from morf.avatar.anchor_blend import angles_between, spread_anchors
from morf.avatar.head_colour import MIN_SHARE, HeadChain, HeadColours, head_orientation, head_share


def head_chain(model, shape: np.ndarray) -> HeadChain:
    """The pose-to-head rotations of the body ``model`` at ``shape`` (1, S)."""
    import torch

    from morf.body.anny_model import reference_rotations

    with torch.no_grad():
        rest = model.rest(torch.as_tensor(shape, dtype=torch.float32).reshape(1, -1))["rest_bone_poses"][0]
    rest = rest.double().cpu().numpy()
    bone = list(model.bone_names).index("head")
    return HeadChain.along(list(model.bone_parents), reference_rotations(model, shape, rest), rest[:, :3, :3], bone)


MAX_HEAD_PASSES = 3  # back-projection passes the head's choice tries
CHOICE_ANCHORS = 12  # head orientations the choice holds a frame aside at
MIN_FACING = 0.3  # as the floor's projection


def head_orientations(frames, chain: HeadChain, camera_R: np.ndarray) -> np.ndarray:
    """(N, 3, 3) each frame's head orientation relative to the camera."""
    return np.stack([head_orientation(camera_R, chain.rotation(r)) for r in frames.rotvecs])


def choose_head_passes(frames, rot: np.ndarray, size: int, per_view: int, how, share: np.ndarray,
                       most: int = MAX_HEAD_PASSES):
    """How many back-projection passes (:mod:`morf.train.back_project`) the head's colours take.
    At up to ``CHOICE_ANCHORS`` head orientations spread over the frames' (``rot`` (N, 3, 3)), the
    frame there is held aside and its head colour projected (``how`` without passes) from the
    ``per_view`` frames whose head is turned most like it, as a head anchor is; it is drawn back
    over the held-aside frame after 0, 1, ... ``most`` passes and scored by SSIM over the head's
    pixels (``share`` (S, S) >= 0.5). The passes up to the first whose mean adds less than
    :data:`~morf.train.back_project.MIN_GAIN`. Frames that agree at the face (a slow turn, a good
    fit) take passes; frames a few pixels apart do not. Returns a
    :class:`~morf.train.back_project.BackProjectionChoice` (its frames: the heads held aside)."""
    from morf.train.back_project import MIN_GAIN, BackProjectionChoice, back_project, drawn_back_ssim
    from morf.train.inpaint import project_rgb_texture

    n = frames.num_frames
    if n <= per_view or most <= 0:
        return BackProjectionChoice(0, (), 0)
    plain = replace(how, back_projections=0)
    region = share >= 0.5
    rows = []
    for a in spread_anchors(rot, min(CHOICE_ANCHORS, n)):
        order = np.argsort(angles_between(rot[a:a + 1], rot)[0], kind="stable")
        held = frames.subset(np.array([a]))
        source = frames.subset(np.sort(order[order != a][:per_view]))
        rgb, seen = project_rgb_texture(source, size, MIN_FACING, plain)
        row = [drawn_back_ssim(rgb, held, MIN_FACING, plain, region)]
        for _ in range(most):
            rgb = back_project(rgb, seen, source, MIN_FACING, plain, 1)
            row.append(drawn_back_ssim(rgb, held, MIN_FACING, plain, region))
        if np.all(np.isfinite(row)):
            rows.append(row)
    if not rows:
        return BackProjectionChoice(0, (), 0)
    mean = np.mean(rows, axis=0)
    passes = 0
    while passes < most and mean[passes + 1] >= mean[passes] + MIN_GAIN:
        passes += 1
    return BackProjectionChoice(passes, tuple(round(float(v), 5) for v in mean[:passes + 2]), len(rows))


def project_head_colours(frames, covered: np.ndarray, base: np.ndarray, count: int, per_view: int, dilate: int,
                         how, chain: HeadChain, camera_R: np.ndarray, share: np.ndarray,
                         rot: np.ndarray | None = None) -> HeadColours:
    """``count`` head colours from a training FrameSet: anchors spread over the frames' head
    orientations (:func:`head_orientation` of ``chain``'s rotation through ``camera_R``), each
    projected (:func:`morf.train.floor_texture.floor_texture` with ``how``) from the ``per_view``
    frames whose head is turned most like it; texels they did not see take ``base`` (3, S, S),
    the avatar's one colour texture (0-1). Only texels whose head ``share`` (S, S) rounds to a
    byte are kept. ``rot``: the frames' head orientations when the caller has them
    (:func:`head_orientations`)."""
    from morf.train.floor_texture import floor_texture

    rot = head_orientations(frames, chain, camera_R) if rot is None else rot
    picked = spread_anchors(rot, count)
    near = np.argsort(angles_between(rot[picked], rot), axis=1, kind="stable")[:, :per_view]
    texels = np.flatnonzero(share.reshape(-1) >= MIN_SHARE).astype(np.int32)
    flat_base = base.reshape(3, -1)[:, texels]
    colours = []
    for idx in near:
        tex, seen = floor_texture(frames.subset(np.sort(idx)), covered, dilate, how=how)
        mix = seen.reshape(-1)[texels].astype(np.float32)[None]
        rgb = mix * tex[:3].reshape(3, -1)[:, texels] + (1 - mix) * flat_base
        colours.append(np.clip(np.rint(rgb.T * 255.0), 0, 255).astype(np.uint8))
    return HeadColours(rot[picked].astype(np.float32), texels,
                       np.clip(np.rint(share.reshape(-1)[texels] * 255.0), 0, 255).astype(np.uint8),
                       np.stack(colours), per_view, chain)
