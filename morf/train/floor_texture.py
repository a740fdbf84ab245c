"""The RGB floor's texture: the training frames projected into an RGB atlas whose texel density
matches the frames.

Texture side (a power of two in [``MIN_SIDE``, ``MAX_SIDE``]): the largest side ``S`` at which
most (``MIN_HIT_SHARE``, half) of the texels the frames see are hit by at least one pixel, every
smaller side passing too. "The texels the frames see" at side ``S`` are the four children of every
texel hit at side ``S / 2``; a pixel that hits a texel also hits its parent (texel indices are
``floor(u * S)``, so the levels nest exactly), so the share is
``hits(S) / (4 * hits(S / 2))`` in [0, 1].

Why this rule: a side whose texels the frames mostly miss gains no detail (the pixels are already
spread one per texel) and leaves holes that must be filled from neighbours, i.e. blur at best; a
side whose texels are nearly all hit averages several pixels into each texel and throws detail
away. The share falls from about 1 (dense; a little under 1 along the edges of the seen region,
where a parent texel is only partly seen) towards 1/4 (one pixel per texel: only one child of each
hit parent is hit) as the side doubles past the frames' sampling; half sits between the two. It
measures the sampling the frames actually give, views of the same surface from several frames
included, rather than a person height or an atlas-scale constant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.avatar.uv_atlas import dilate_texture
from morf.train.frames import FrameSet
from morf.train.texel_splat import Projection

MIN_SIDE = 64
MAX_SIDE = 1024
MIN_HIT_SHARE = 0.5


@dataclass(frozen=True)
class FloorSize:
    """The chosen texture side and the measurements behind it.

    Fields:
        size: texture side in texels.
        hit_share: side -> share of the texels seen (children of the texels hit at half the side)
            that at least one pixel hits, for every side from ``MIN_SIDE`` to ``MAX_SIDE``.
    """

    size: int
    hit_share: dict[int, float]

    def describe(self) -> str:
        shares = ", ".join(f"{s}: {v:.2f}" for s, v in self.hit_share.items())
        return (f"texture {self.size}x{self.size}: the largest side at which at least {MIN_HIT_SHARE:.0%} of the "
                f"texels the frames see are hit by a pixel (share hit per side: {shares})")


def texel_hits(frames: FrameSet, size: int, min_facing: float = 0.3) -> np.ndarray:
    """(size, size) bool: texels hit by at least one projecting pixel of any frame."""
    from morf.train.inpaint import projected_texels

    hit = np.zeros((size, size), bool)
    for i in range(frames.num_frames):
        _, row, col = projected_texels(frames, i, size, min_facing)
        hit[row, col] = True
    return hit


def hit_shares(frames: FrameSet, min_facing: float = 0.3) -> dict[int, float]:
    """Side -> ``hits(S) / (4 hits(S / 2))`` for S = MIN_SIDE .. MAX_SIDE (see the module docstring)."""
    counts = {}
    hit = texel_hits(frames, MAX_SIDE, min_facing)
    side = MAX_SIDE
    while side >= MIN_SIDE // 2:
        counts[side] = int(hit.sum())
        half = side // 2
        hit = hit.reshape(half, 2, half, 2).any(axis=(1, 3))
        side = half
    return {s: counts[s] / max(4 * counts[s // 2], 1) for s in sorted(counts) if s >= MIN_SIDE}


def choose_floor_size(frames: FrameSet, min_facing: float = 0.3) -> FloorSize:
    """The texture side for ``frames`` by the rule of the module docstring."""
    shares = hit_shares(frames, min_facing)
    size = MIN_SIDE
    for s in sorted(shares):
        if s > MIN_SIDE and shares[s] < MIN_HIT_SHARE:
            break
        size = s
    return FloorSize(size, {s: round(v, 4) for s, v in shares.items()})


def floor_texture(frames: FrameSet, covered: np.ndarray, dilate: int = 4, min_facing: float = 0.3,
                  how: Projection = Projection()) -> tuple[np.ndarray, np.ndarray]:
    """The floor's (4, S, S) float32 texture for an (S, S) atlas coverage, and the (S, S) seen map.

    Channels 0-2: every texel hit by a pixel holds the mean colour of its pixels, projected as
    ``how`` says (:func:`morf.train.inpaint.project_rgb_texture`, exactly, then ``how.back_projections``
    passes of :func:`morf.train.back_project.back_project`; the floor itself keeps the default, the
    plain mean); every other texel of the UV islands,
    pinholes between hit texels included, is filled from its neighbours (Telea); the islands are
    then grown ``dilate`` texels so bilinear lookups at seams never blend in black. Channel 3: 1
    everywhere (the coverage, once sampled). The seen map is the hit map with pinholes closed
    (:func:`morf.train.inpaint.close_seen`), for reporting how much of the body the frames show.
    """
    from morf.train.inpaint import close_seen, fill_unseen, project_rgb_texture

    size = covered.shape[0]
    rgb, hit = project_rgb_texture(frames, size, min_facing, how)
    if how.back_projections > 0:
        from morf.train.back_project import back_project

        rgb = back_project(rgb, hit, frames, min_facing, how, how.back_projections)
    islands = covered | hit
    filled = fill_unseen(rgb, hit, islands)
    filled, _ = dilate_texture(filled, islands, dilate)
    texture = np.concatenate([filled.transpose(2, 0, 1), np.ones((1, size, size), np.float32)])
    return np.ascontiguousarray(texture, dtype=np.float32), close_seen(hit) & covered
