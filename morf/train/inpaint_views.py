"""What the inpainting fine-tune takes besides the frames: the texels to fill and a maker of the
pseudo views that show them. A file of its own because both the training loop, which receives it,
and the run session, which runs the fine-tune, name it; neither imports the other for it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import torch


@dataclass(frozen=True)
class InpaintViews:
    """What the inpainting fine-tune needs besides the frames.

    Fields:
        covered: (Ht, Wt) bool texels inside the UV islands.
        make_views: callable () -> (uv (V, H, W, 2) float tensor, uv_mask (V, H, W) bool tensor),
            rasterizations in extreme poses / views (called once, after the main stage).
    """

    covered: np.ndarray
    make_views: Callable[[], tuple[torch.Tensor, torch.Tensor]]
