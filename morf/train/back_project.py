"""Back-projection of the frames into the colour texture, and the choice of how far to take it.

The projection (:func:`morf.train.inpaint.project_rgb_texture`) gives each texel the weighted mean
of the pixels that land on it. Drawn back through the renderer's bilinear lookup, that texture is
blurred twice: once by the splat's sharing of each pixel among four texels, once by the lookup. At
the head, where the atlas holds about one texel per pixel the player draws, what is lost is the
finest detail: projecting a frame and drawing it back over itself kept 38 % of its head's
high-frequency energy at 256^2 (People-Snapshot, 512 px frames).

Iterative back-projection (Irani and Peleg 1991, the super-resolution classic) takes it back: the
texture is sampled at every pixel the projection used, the residual (pixel minus lookup) is
projected as the colours were, and added. Each pass is a Jacobi step on the least-squares texture
whose lookup matches the frames. Where the frames agree with one another (a slow turn, sharp
frames, a good fit) the detail comes back: the frame drawn over itself kept 92 % of its head's
energy after three passes, and its head's shift-tolerant SSIM rose from 0.838 to 0.870. Where they
do not (fast motion, motion blur, small heads, a fit a few pixels off) the passes sharpen the
frames' disagreement into noise.

So whether to take a pass is decided on the capture itself (:func:`choose_back_projections`): the
texture is projected from every other frame, and each pass scored on the frames in between by the
SSIM of the texture drawn back over them (inside the projected pixels). The passes stop where that
score stops rising, or at ``MAX_BACK_PROJECTIONS``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

# passes the choice tries: on the demo's capture a second and third pass sharpened the head no further
# (shift-tolerant SSIM 0.854 after 1 and after 3) and cost person PSNR and flicker (docs/avatar.md)
MAX_BACK_PROJECTIONS = 1
CHOICE_FRAMES = 24  # held-aside frames scored for the choice, spread over the capture
MIN_GAIN = 1e-4  # SSIM a pass must add to be taken


@dataclass(frozen=True)
class BackProjectionChoice:
    """Fields: passes: the number chosen; scores: the held-aside frames' mean SSIM after 0, 1, ...
    passes (up to the first pass that did not pay); frames: how many frames were scored."""

    passes: int
    scores: tuple[float, ...]
    frames: int

    def describe(self) -> str:
        got = " / ".join(f"{s:.4f}" for s in self.scores)
        return (f"{self.passes} back-projection pass(es), chosen on {self.frames} frames held aside "
                f"(their SSIM drawn back after 0-{len(self.scores) - 1} passes: {got})")


def _frame_pixels(frames, i: int, size: int, min_facing: float, how):
    """(rgb (P, 3), the bilinear lookups [(texel index (P,), weight (P,))], facing weights (P,) or
    None) of the pixels of frame ``i`` the projection takes, or None where it takes none."""
    from morf.train.inpaint import pixel_colours
    from morf.train.texel_splat import texel_weights

    got = pixel_colours(frames, i, min_facing, how)
    if got is None:
        return None
    ok, rgb, facing = got
    return rgb, texel_weights(frames.uv[i][ok], size, True), facing  # the renderer's lookup is bilinear


def _looked_up(tex: np.ndarray, lookups) -> np.ndarray:
    """(P, 3): the flat (S * S, 3) texture ``tex`` at pixels' bilinear ``lookups`` (texel, weight)."""
    return sum(w[:, None] * tex[lin] for lin, w in lookups)


def back_project(rgb: np.ndarray, seen: np.ndarray, frames, min_facing: float, how, passes: int) -> np.ndarray:
    """(S, S, 3) float32: the projected colours ``rgb`` (S, S, 3) refined by ``passes`` passes of
    back-projection against ``frames`` (the pixels the projection used, weighted as it weighted
    them); texels outside ``seen`` (S, S) stay 0."""
    size = rgb.shape[0]
    tex = rgb.reshape(-1, 3).astype(np.float64)
    keep = seen.reshape(-1)
    for _ in range(passes):
        acc = np.zeros_like(tex)
        cnt = np.zeros(len(tex))
        for i in range(frames.num_frames):
            got = _frame_pixels(frames, i, size, min_facing, how)
            if got is None:
                continue
            px, lookups, facing = got
            resid = px - _looked_up(tex, lookups)
            whole = np.logical_and.reduce([keep[lin] | (w <= 0) for lin, w in lookups])
            for lin, w in lookups:  # a lookup that reaches an unseen texel (0 here, filled later) is left out
                w = w * whole if facing is None else w * whole * facing
                cnt += np.bincount(lin, weights=w, minlength=len(tex))
                for c in range(3):
                    acc[:, c] += np.bincount(lin, weights=w * resid[:, c], minlength=len(tex))
        step = keep & (cnt > 1e-9)
        tex[step] += acc[step] / cnt[step, None]
        np.clip(tex, 0.0, 1.0, out=tex)
    tex[~keep] = 0.0
    return tex.reshape(size, size, 3).astype(np.float32)


def drawn_back_ssim(texture: np.ndarray, frames, min_facing: float, how, region: np.ndarray | None = None) -> float:
    """Mean over ``frames`` of the SSIM of ``texture`` (S, S, 3) looked up at each frame's pixels
    against the frame, over the pixels a projection would take from it (the rest grey in both);
    with ``region`` (S, S) bool, only over those whose texel lies in it (a part of the body)."""
    import torch

    from morf.avatar.metrics import ssim_map
    from morf.train.inpaint import projecting_pixels
    from morf.train.texel_splat import texel_weights

    flat = texture.reshape(-1, 3).astype(np.float64)
    out = []
    for i in range(frames.num_frames):
        ok = projecting_pixels(frames, i, min_facing, how.edge_inset)
        if region is not None:
            ok = ok & _in_region(frames.uv[i], region)
        if ok.sum() < 64:
            continue
        drawn = np.full(ok.shape + (3,), 0.5)
        drawn[ok] = _looked_up(flat, texel_weights(frames.uv[i][ok], texture.shape[0], True))
        real = np.where(ok[..., None], frames.images[i].astype(np.float64) / 255, 0.5)
        s = ssim_map(*(torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1), np.float64))[None]
                       for a in (drawn, real)))[0].mean(0).numpy()
        r = (ok.shape[0] - s.shape[0]) // 2  # the map's valid part
        inside = ok[r:r + s.shape[0], r:r + s.shape[1]]
        if inside.any():
            out.append(float(s[inside].mean()))
    return float(np.mean(out)) if out else float("nan")


def _in_region(uv: np.ndarray, region: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels whose UVs ((H, W, 2) uint16 fixed point, v up) fall in a texel of ``region`` (S, S)."""
    from morf.train.frames import UV_SCALE

    size = region.shape[0]
    col = np.clip((uv[..., 0].astype(np.float64) / UV_SCALE * size).astype(np.int64), 0, size - 1)
    row = np.clip(((1 - uv[..., 1].astype(np.float64) / UV_SCALE) * size).astype(np.int64), 0, size - 1)
    return region[row, col]


def choose_back_projections(frames, size: int, min_facing: float, how,
                            most: int = MAX_BACK_PROJECTIONS) -> BackProjectionChoice:
    """How many back-projection passes ``frames`` support: the colours projected (as ``how`` says,
    without passes) from every other frame, drawn back over at most ``CHOICE_FRAMES`` of the frames
    in between after each pass; the passes up to the first that adds less than ``MIN_GAIN`` SSIM
    (at most ``most``). Fewer than 4 frames: 0."""
    from morf.train.inpaint import project_rgb_texture

    n = frames.num_frames
    if n < 4 or most <= 0:
        return BackProjectionChoice(0, (), 0)
    odd = np.arange(1, n, 2)
    scored = frames.subset(odd[np.linspace(0, len(odd) - 1, min(CHOICE_FRAMES, len(odd))).round().astype(int)])
    plain = replace(how, back_projections=0)
    source = frames.subset(np.arange(0, n, 2))
    rgb, seen = project_rgb_texture(source, size, min_facing, plain)
    scores = [drawn_back_ssim(rgb, scored, min_facing, plain)]
    passes = 0
    while passes < most:  # one pass at a time: stop at the first that does not pay
        rgb = back_project(rgb, seen, source, min_facing, plain, 1)
        scores.append(drawn_back_ssim(rgb, scored, min_facing, plain))
        if scores[-1] < scores[-2] + MIN_GAIN:
            break
        passes += 1
    return BackProjectionChoice(passes, tuple(round(s, 5) for s in scores), scored.num_frames)
