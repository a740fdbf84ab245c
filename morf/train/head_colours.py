"""After training: the head's colour by the head's own orientation (:mod:`morf.avatar.head_colour`),
projected with the view colours when the run's config asks for them (``head_view_colours`` > 0)."""

from __future__ import annotations

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


def project_head_colours(frames, covered: np.ndarray, base: np.ndarray, count: int, per_view: int, dilate: int,
                         how, chain: HeadChain, camera_R: np.ndarray, share: np.ndarray) -> HeadColours:
    """``count`` head colours from a training FrameSet: anchors spread over the frames' head
    orientations (:func:`head_orientation` of ``chain``'s rotation through ``camera_R``), each
    projected (:func:`morf.train.floor_texture.floor_texture` with ``how``) from the ``per_view``
    frames whose head is turned most like it; texels they did not see take ``base`` (3, S, S),
    the avatar's one colour texture (0-1). Only texels whose head ``share`` (S, S) rounds to a
    byte are kept."""
    from morf.train.floor_texture import floor_texture

    rot = np.stack([head_orientation(camera_R, chain.rotation(r)) for r in frames.rotvecs])
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
                       np.stack(colours), per_view, chain, np.asarray(camera_R, np.float64))
