"""The images behind the comparison sheet and the space-time slices: a few frames of a sequence
and one image column of every frame, for the renders and the real frames alike, composited over
the same flat colour the metrics use (:func:`morf.avatar.metrics.composite_over`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.avatar.metrics import composite_over
from morf.train.frames import FrameSet
from morf.train.trained_avatar import render_batch


@dataclass(frozen=True)
class SequenceViews:
    """Fields: rows: (R, H, W, 3) uint8 the chosen frames; slice: (H, T, 3) uint8 one image
    column of every frame, in order (a y-t slice)."""

    rows: np.ndarray
    slice: np.ndarray


def sheet_rows(num_frames: int, count: int = 4) -> list[int]:
    """Up to ``count`` frame positions spread evenly over a sequence, first and last included."""
    return sorted({int(round(x)) for x in np.linspace(0, num_frames - 1, min(count, num_frames))})


def person_column(frames: FrameSet) -> float:
    """The image column through the person's centre, as a fraction of the width: the median over
    frames of the person mask's mean x (0.5 when no frame shows the person)."""
    xs = [np.nonzero(m)[1].mean() for m in frames.masks if m.any()]
    return float((np.median(xs) + 0.5) / frames.resolution) if xs else 0.5


def column_index(fraction: float, width: int) -> int:
    return min(width - 1, max(0, int(fraction * width)))


def _to_uint8(x: torch.Tensor) -> np.ndarray:
    return (x.clamp(0, 1).permute(0, 2, 3, 1).cpu().numpy() * 255 + 0.5).astype(np.uint8)


def _views(images, frames: FrameSet, rows: list[int], column: float, batch: int) -> SequenceViews:
    """``images(batch) -> (B, 3, H, W)`` composited frames, gathered into rows and a slice."""
    col = column_index(column, frames.resolution)
    kept, cols = {}, []
    for s in range(0, frames.num_frames, batch):
        idx = list(range(s, min(s + batch, frames.num_frames)))
        img = _to_uint8(images(frames.batch(idx)))
        cols.append(img[:, :, col])
        kept.update({i: img[j] for j, i in enumerate(idx) if i in rows})
    return SequenceViews(np.stack([kept[i] for i in rows]), np.concatenate(cols).transpose(1, 0, 2).copy())


@torch.no_grad()
def render_views(avatar, frames: FrameSet, colour: torch.Tensor, rows: list[int], column: float,
                 batch: int = 4) -> SequenceViews:
    """A trained avatar's renders of ``frames`` over ``colour``."""
    def images(b):
        rgb, alpha = render_batch(avatar, b)
        return composite_over(rgb, alpha, colour)

    return _views(images, frames, rows, column, batch)


def real_views(frames: FrameSet, colour: torch.Tensor, rows: list[int], column: float) -> SequenceViews:
    """The real frames (their person over ``colour``, as the metrics compare them)."""
    return _views(lambda b: composite_over(b.image * b.mask, b.mask, colour), frames, rows, column, 16)
