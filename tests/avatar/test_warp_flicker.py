"""The flicker that forgives misregistration (morf/avatar/warp_flicker.py): a render a steady few
pixels off the real frames scores as steady (where the plain flicker charges its detail), a render
whose texture pops from frame to frame does not, and a render equal to the real frames scores as they do."""

from __future__ import annotations

import numpy as np


def _scene(shift_px: int = 0, pop: float = 0.0, frames: int = 6, size: int = 96, seed: int = 0):
    """A textured disc moving 2 px a frame over a flat backdrop: reals, renders (the same texture,
    drawn ``shift_px`` to the right; ``pop``: fresh noise of that amplitude each frame) and masks."""
    rng = np.random.default_rng(seed)
    tex = rng.random((size, size + 64, 3)).astype(np.float32)
    tex = (tex + np.roll(tex, 1, 0) + np.roll(tex, 1, 1) + np.roll(tex, (1, 1), (0, 1))) / 4  # some smoothness
    yy, xx = np.mgrid[:size, :size]
    reals, renders, masks = [], [], []
    for t in range(frames):
        x0 = 2 * t
        disc = (yy - size / 2) ** 2 + (xx - size / 2 - x0 + 10) ** 2 < (size / 3) ** 2
        real = np.where(disc[..., None], tex[:, 64 - x0:64 - x0 + size], 0.5)
        drawn = np.roll(disc, shift_px, 1)
        render = np.where(drawn[..., None], np.roll(tex[:, 64 - x0:64 - x0 + size], shift_px, 1), 0.5)
        if pop:
            render = np.where(drawn[..., None], np.clip(render + pop * rng.standard_normal(render.shape), 0, 1), render)
        reals.append(real); renders.append(render.astype(np.float32)); masks.append(disc.astype(np.float32))
    return np.stack(renders), np.stack(reals).astype(np.float32), np.stack(masks)


def test_a_steady_offset_costs_little_and_popping_texels_cost_much():
    import torch

    from morf.avatar.metrics import temporal_flicker
    from morf.avatar.warp_flicker import warping_errors

    def both(renders, reals, masks):
        plain = temporal_flicker(*(torch.from_numpy(a).permute(0, 3, 1, 2) for a in (renders, reals)),
                                 torch.from_numpy(masks)[:, None])
        return plain, warping_errors(renders, reals, masks)

    exact = both(*_scene())
    shifted = both(*_scene(shift_px=2))
    popping = both(*_scene(pop=0.1))
    assert exact[1][0] == exact[1][1]  # the render is the real sequence: its error is the floor
    # two pixels off: the plain flicker charges the texture's detail, the warping error barely moves
    assert shifted[0] > 5 * max(exact[0], 1e-3)
    assert shifted[1][0] < exact[1][0] + 0.3 * (popping[1][0] - exact[1][0])
    assert popping[1][0] > 3 * exact[1][0]  # texels that change from frame to frame do cost


def test_too_short_or_empty_sequences_give_none():
    from morf.avatar.warp_flicker import warping_errors

    renders, reals, masks = _scene(frames=2)
    assert warping_errors(renders[:1], reals[:1], masks[:1]) is None
    assert warping_errors(renders, reals, np.zeros_like(masks)) is None
