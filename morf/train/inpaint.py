"""Post-training inpainting of body parts the video never showed (MoRF Sec. 4.2).

1. Project the training frames into an RGB texture through their rasterizations: every texel
   averages the colours of the pixels that see it in frames where the person mask covers it and
   the surface faces the camera (|cos| >= ``min_facing``); those texels are "seen".
2. Fill the unseen texels of the UV islands with nearby colour (``cv2.inpaint``, Telea).
3. Render pseudo ground truth in extreme poses and views with that RGB texture (the caller gives
   the rasterizations, see :mod:`morf.train.pseudo_views`).
4. Fine-tune the baked neural texture with L1 ONLY on pixels whose texels were never seen; the
   renderer is frozen and the texture gradient is masked to unseen texels, so everything the
   video did show stays exactly as trained.
"""

from __future__ import annotations

import cv2
import numpy as np
import torch

from morf.avatar.texture import sample_texture
from morf.train.frames import FrameSet
from morf.train.texel_splat import Projection, shrunk_means, texel_weights


def projected_texels(frames: FrameSet, i: int, size: int, min_facing: float = 0.3):
    """The pixels of frame ``i`` that project into the texture and the texel each one hits.

    A pixel projects when it lies inside the person mask and the mesh coverage and its surface
    faces the camera (|cos| >= ``min_facing``); it hits the texel its UV falls in.
    Returns:
        ok: (H, W) bool projecting pixels; row, col: (P,) int64 texel of each, in ``ok`` order.
    """
    ok = projecting_pixels(frames, i, min_facing)
    (lin, _), = texel_weights(frames.uv[i][ok], size, bilinear=False)
    row, col = np.divmod(lin, size)
    return ok, row, col


def projecting_pixels(frames: FrameSet, i: int, min_facing: float = 0.3, inset: int = 0) -> np.ndarray:
    """(H, W) bool: the pixels of frame ``i`` inside the person mask and the mesh coverage whose
    surface faces the camera (|cos| >= ``min_facing``); with ``inset`` > 0 only those at least
    that many pixels inside the mask's outline (the mask eroded by a disc of that radius)."""
    mask = frames.masks[i]
    if inset > 0:
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * inset + 1, 2 * inset + 1))
        mask = cv2.erode(mask.astype(np.uint8), disc, borderType=cv2.BORDER_REPLICATE).astype(bool)
    return frames.uv_mask[i] & mask & (frames.facing[i] >= int(round(min_facing * 255)))


def pixel_colours(frames: FrameSet, i: int, min_facing: float, how: Projection):
    """(ok (H, W) bool, rgb (P, 3) float64 in [0, 1], facing weights (P,) or None) of the pixels of
    frame ``i`` that a projection as ``how`` says takes (:func:`projecting_pixels`), or None where
    it takes none."""
    ok = projecting_pixels(frames, i, min_facing, how.edge_inset)
    if not ok.any():
        return None
    facing = (frames.facing[i][ok].astype(np.float64) / 255) ** how.facing_power if how.facing_power else None
    return ok, frames.images[i][ok].astype(np.float64) / 255, facing


def project_rgb_texture(frames: FrameSet, size: int, min_facing: float = 0.3,
                        how: Projection = Projection()) -> tuple[np.ndarray, np.ndarray]:
    """Average the training frames' colours per texel (pixels as in :func:`projected_texels`).

    ``how.facing_power`` p > 0 weights each pixel by its facing |cos| ** p instead of equally. The
    frames of a capture disagree by the fit's error (a few pixels at the face): the plain mean
    over every frame that sees a texel blends those copies into a ghosted blur (two pairs of eyes),
    and a texel seen at a grazing angle is stretched over many texels. Weighting by how squarely
    each frame sees the surface keeps the few frames that see it best, so the colour is sharp where
    some frame saw it well (p = 0: the plain mean).

    ``how.bilinear`` shares each pixel among the four texels around its UV, and ``how.prior_count`` > 0
    draws a texel seen by few pixels towards its neighbourhood (:mod:`morf.train.texel_splat`);
    the defaults are the plain nearest-texel mean. (``how.back_projections`` is applied by
    :func:`morf.train.floor_texture.floor_texture`, not here.)

    Returns:
        rgb: (size, size, 3) float32 in [0, 1] (0 where unseen); seen: (size, size) bool.
    """
    acc = np.zeros((size * size, 3), np.float64)
    cnt = np.zeros(size * size, np.float64)
    for i in range(frames.num_frames):
        got = pixel_colours(frames, i, min_facing, how)
        if got is None:
            continue
        ok, rgb, facing = got
        for lin, w in texel_weights(frames.uv[i][ok], size, how.bilinear):
            w = facing if w is None else (w if facing is None else w * facing)
            cnt += np.bincount(lin, weights=w, minlength=size * size)
            for c in range(3):
                acc[:, c] += np.bincount(lin, weights=rgb[:, c] if w is None else rgb[:, c] * w,
                                         minlength=size * size)
    seen = cnt > 0  # facing >= min_facing > 0: a seen texel's weight is positive
    out = np.zeros_like(acc)
    if how.prior_count > 0:
        shrunk = shrunk_means(acc.reshape(size, size, 3), cnt.reshape(size, size), how.prior_count).reshape(-1, 3)
        out[seen] = shrunk[seen]
    else:
        out[seen] = acc[seen] / cnt[seen, None]
    return out.reshape(size, size, 3).astype(np.float32), seen.reshape(size, size)


def close_seen(seen: np.ndarray, radius: int = 2) -> np.ndarray:
    """Close pinholes in the seen map (texels between seen pixels at coarse image sampling)."""
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
    return cv2.morphologyEx(seen.astype(np.uint8), cv2.MORPH_CLOSE, k).astype(bool)


def fill_unseen(rgb: np.ndarray, seen: np.ndarray, covered: np.ndarray, radius: int = 5) -> np.ndarray:
    """Fill covered-but-unseen texels with nearby colour (OpenCV Telea inpainting).

    Args:
        rgb: (H, W, 3) float [0, 1]; seen, covered: (H, W) bool.
    Returns:
        (H, W, 3) float32 filled texture.
    """
    hole = (covered & ~seen).astype(np.uint8)
    if not hole.any() or not seen.any():
        return rgb.astype(np.float32)
    img = (np.clip(rgb, 0, 1) * 255).astype(np.uint8)
    # Texels outside every island take part as holes too, so colour flows across island gaps
    # instead of bleeding black in from the background.
    filled = cv2.inpaint(img, (~seen).astype(np.uint8), radius, cv2.INPAINT_TELEA)
    out = rgb.astype(np.float32).copy()
    out[hole.astype(bool)] = filled[hole.astype(bool)].astype(np.float32) / 255
    return out


def finetune_unseen(texture: torch.Tensor, renderer: torch.nn.Module, uv: torch.Tensor, uv_mask: torch.Tensor,
                    rgb_texture: torch.Tensor, seen: torch.Tensor, steps: int, lr: float = 5e-3,
                    batch_size: int = 2, seed: int = 0) -> tuple[torch.Tensor, list[float]]:
    """Fine-tune unseen texels of a (baked) neural texture against pseudo ground truth.

    Args:
        texture: (C, Ht, Wt) neural texture; renderer: frozen during this step.
        uv: (V, H, W, 2), uv_mask: (V, H, W) rasterizations of the pseudo views.
        rgb_texture: (3, Ht, Wt) filled RGB texture; seen: (Ht, Wt) bool texels seen in training.
    Returns:
        the new texture (C, Ht, Wt) and the loss per step.
    """
    device = texture.device
    unseen = (~seen).to(device=device, dtype=texture.dtype)
    with torch.no_grad():
        target_rgb = sample_texture(rgb_texture.to(device), uv, uv_mask)
        # a pixel is supervised when the texel it shows was never seen (nearest-texel decision)
        unseen_px = (sample_texture(unseen[None], uv, uv_mask) > 0.5) & uv_mask.unsqueeze(1)
        target_mask = uv_mask.unsqueeze(1).to(texture.dtype)
    tex = texture.detach().clone().requires_grad_(True)
    opt = torch.optim.Adam([tex], lr=lr)
    was_training = renderer.training
    flags = [p.requires_grad for p in renderer.parameters()]
    renderer.eval().requires_grad_(False)
    history: list[float] = []
    gen = torch.Generator().manual_seed(seed)
    V = uv.shape[0]
    try:
        for _ in range(steps):
            idx = torch.randperm(V, generator=gen)[:batch_size].to(device)
            w = unseen_px[idx].to(tex.dtype)
            if w.sum() == 0:
                history.append(0.0)
                continue
            out = renderer(sample_texture(tex, uv[idx], uv_mask[idx]))
            rgb, mask = out[:, :3], torch.sigmoid(out[:, 3:])
            err = (rgb - target_rgb[idx]).abs().sum(1, keepdim=True) / 3 + (mask - target_mask[idx]).abs()
            loss = (err * w).sum() / w.sum()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            tex.grad.mul_(unseen)  # seen texels keep exactly their trained values
            opt.step()
            history.append(float(loss.detach()))
    finally:
        for p, f in zip(renderer.parameters(), flags):
            p.requires_grad_(f)
        renderer.train(was_training)
    return tex.detach(), history
