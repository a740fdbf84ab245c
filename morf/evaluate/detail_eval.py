"""A trained avatar's detail scores on a sequence: the person, the head and the hands of every
frame (:mod:`morf.evaluate.regions`) scored with :mod:`morf.evaluate.detail`, and the enlarged
head crops of the comparison sheet's rows.

Per group (person, head, hands: both hands pooled) the result holds the mean over the scored
regions of ``psnr``, ``ssim_shift`` and ``gmsd``, ``hf_ratio`` as the ratio of the summed energies
(so regions with almost no real detail do not swing it), ``hf_ratio_inside`` the same inside the
real person away from its mask's edge, and ``count``, the regions scored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.evaluate.detail import RegionScores, inside_mask, region_scores
from morf.evaluate.regions import GROUPS, frame_boxes, square_box
from morf.train.trained_avatar import render_batch

DETAIL_SCORES = ("psnr", "ssim_shift", "gmsd", "hf_ratio", "hf_ratio_inside")
DETAIL_KEYS = tuple(f"{g}_{s}" for g in GROUPS for s in DETAIL_SCORES + ("count",))


@dataclass(frozen=True)
class DetailResult:
    """Fields: scores: {"<group>_<score>": value} for the groups of ``GROUPS`` and the scores of
    ``DETAIL_SCORES`` plus ``count`` (None where no region was scored); resolution: the side the
    frames were scored at; max_shift: the tolerated shift in pixels there; crops: {sheet row:
    (real, render)} (h, h, 3) uint8 head crops, rows without a visible head left out;
    head_frames: :func:`head_frames` of the scored frames."""

    scores: dict
    resolution: int
    max_shift: int
    crops: dict
    head_frames: tuple = ()

    def to_dict(self) -> dict:
        """What eval.json keeps of it: the scores, ``resolution``, ``max_shift`` and ``head_frames``."""
        return {**self.scores, "resolution": self.resolution, "max_shift": self.max_shift,
                "head_frames": list(self.head_frames)}


def summarize_detail(frames: list[dict[str, RegionScores]]) -> dict:
    """The flat ``DetailResult.scores`` of per-frame {region: RegionScores} dicts."""
    out = {}
    for group, regions in GROUPS.items():
        got = [f[r] for f in frames for r in regions if r in f]
        for s in ("psnr", "ssim_shift", "gmsd"):
            vals = [getattr(x, s) for x in got if np.isfinite(getattr(x, s))]
            out[f"{group}_{s}"] = round(float(np.mean(vals)), 5) if vals else None
        for key, a, b in (("hf_ratio", "hf_render", "hf_real"), ("hf_ratio_inside", "hf_render_inside", "hf_real_inside")):
            real = sum(getattr(x, b) for x in got)
            out[f"{group}_{key}"] = round(sum(getattr(x, a) for x in got) / real, 5) if real > 0 else None
        out[f"{group}_count"] = len(got)
    return out


def head_frames(frames: list[dict[str, RegionScores]], frame_ids, max_shift: int) -> tuple[dict, ...]:
    """Per frame with a scored head, in frame order: {"frame": its id in ``frame_ids``,
    "ssim_shift", "shift": [dy, dx], "at_bound": whether |dy| or |dx| is ``max_shift``}."""
    out = []
    for fid, f in zip(frame_ids, frames, strict=True):  # every target names each of its frames
        if "head" in f:
            h = f["head"]
            out.append({"frame": int(fid), "ssim_shift": round(float(h.ssim_shift), 5), "shift": list(h.shift),
                        "at_bound": max(abs(h.shift[0]), abs(h.shift[1])) >= max_shift})
    return tuple(out)


def _uint8(x: torch.Tensor) -> np.ndarray:
    return (x.clamp(0, 1).permute(1, 2, 0).numpy() * 255 + 0.5).astype(np.uint8)


@torch.no_grad()
def detail_scores(avatar, frames, colour: torch.Tensor, atlas: np.ndarray, max_shift: int,
                  rows=(), frame_ids=None) -> DetailResult:
    """Render every frame of ``frames`` (a FrameSet) with ``avatar`` over ``colour`` and score its
    regions; keep the head crops of the frame positions ``rows``. ``frame_ids`` name the frames in
    :attr:`DetailResult.head_frames` (default: their positions)."""
    from morf.avatar.metrics import composite_over
    from morf.body.parts import pixel_parts

    per, crops = [], {}
    for i in range(frames.num_frames):
        b = frames.batch([i])
        rgb, alpha = render_batch(avatar, b)
        pred = composite_over(rgb, alpha, colour)[0]
        gt = composite_over(b.image * b.mask, b.mask, colour)[0]
        parts = pixel_parts(b.uv[0].numpy(), frames.uv_mask[i], atlas)
        boxes = frame_boxes(parts, frames.masks[i] | frames.uv_mask[i])
        inside, mine = inside_mask(frames.masks[i]), inside_mask(alpha[0, 0].numpy() > 0.5)
        per.append({n: region_scores(pred, gt, box, max_shift, inside, mine) for n, box in boxes.items()})
        if i in rows and "head" in boxes:
            y0, x0, y1, x1 = square_box(boxes["head"], *parts.shape)
            crops[i] = (_uint8(gt[:, y0:y1, x0:x1]), _uint8(pred[:, y0:y1, x0:x1]))
    ids = range(frames.num_frames) if frame_ids is None else frame_ids
    return DetailResult(summarize_detail(per), frames.resolution, max_shift, crops, head_frames(per, ids, max_shift))


def _moved(img: torch.Tensor, dy: int, dx: int, colour: torch.Tensor) -> torch.Tensor:
    """(C, H, W) ``img`` moved by whole pixels (down ``dy``, right ``dx``), uncovered pixels ``colour`` ((C,))."""
    _, H, W = img.shape
    out = colour.to(img).view(-1, 1, 1).expand(img.shape[0], H, W).clone()
    ys, yd = (slice(0, H - dy), slice(dy, H)) if dy >= 0 else (slice(-dy, H), slice(0, H + dy))
    xs, xd = (slice(0, W - dx), slice(dx, W)) if dx >= 0 else (slice(-dx, W), slice(0, W + dx))
    if abs(dy) < H and abs(dx) < W:
        out[:, yd, xd] = img[:, ys, xs]
    return out


def _moved_mask(mask: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """(H, W) bool ``mask`` moved as :func:`_moved` moves an image, uncovered pixels False."""
    t = torch.from_numpy(np.asarray(mask, np.float32))[None]
    return _moved(t, dy, dx, torch.zeros(1))[0].numpy() > 0.5


def _centre(box) -> np.ndarray:
    return np.array([(box[0] + box[2]) / 2, (box[1] + box[3]) / 2])


@torch.no_grad()
def copy_scores(frames, copies, colour: torch.Tensor, atlas: np.ndarray, max_shift: int, rows=(),
                frame_ids=None) -> DetailResult:
    """The detail scores of other real frames copied in place of a render: ``copies``, a FrameSet
    with one frame per frame of ``frames`` (rasterized in its own fit), over ``colour``, scored in
    ``frames``' regions as :func:`detail_scores` scores an avatar. Each region of a copy is first
    moved by whole pixels so that the copy's own box of that region (from its fit) is centred on
    the frame's: what is left is how the region looks, not where the person stood. A region the
    copy does not show is not scored. With each held-out frame's nearest training frame this is the
    capture's own change from frame to frame (:mod:`morf.evaluate.reference`)."""
    from morf.avatar.metrics import composite_over
    from morf.body.parts import pixel_parts

    per, crops = [], {}
    for i in range(frames.num_frames):
        b, c = frames.batch([i]), copies.batch([i])
        gt = composite_over(b.image * b.mask, b.mask, colour)[0]
        copy = composite_over(c.image * c.mask, c.mask, colour)[0]
        parts = pixel_parts(b.uv[0].numpy(), frames.uv_mask[i], atlas)
        boxes = frame_boxes(parts, frames.masks[i] | frames.uv_mask[i])
        theirs = frame_boxes(pixel_parts(c.uv[0].numpy(), copies.uv_mask[i], atlas), copies.masks[i] | copies.uv_mask[i])
        scores, inside = {}, inside_mask(frames.masks[i])
        for name in boxes.keys() & theirs.keys():
            dy, dx = np.round(_centre(boxes[name]) - _centre(theirs[name])).astype(int)
            moved = _moved(copy, int(dy), int(dx), colour)
            mine = inside_mask(_moved_mask(copies.masks[i], int(dy), int(dx)))
            scores[name] = region_scores(moved, gt, boxes[name], max_shift, inside, mine)
            if name == "head" and i in rows:
                y0, x0, y1, x1 = square_box(boxes["head"], *parts.shape)
                crops[i] = (_uint8(gt[:, y0:y1, x0:x1]), _uint8(moved[:, y0:y1, x0:x1]))
        per.append(scores)
    ids = range(frames.num_frames) if frame_ids is None else frame_ids
    return DetailResult(summarize_detail(per), frames.resolution, max_shift, crops, head_frames(per, ids, max_shift))
