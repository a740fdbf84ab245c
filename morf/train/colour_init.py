"""The neural texture's colour channels, started from the training frames themselves.

With ``RendererConfig.rgb_skip`` the renderer adds its output to texture channels 0-2, so those
channels are colour: they start as the frames projected into the texture (every texel the mean
colour of the pixels that see it, :func:`morf.train.inpaint.project_rgb_texture`), texels never
seen filled from their neighbours, and the islands grown a few texels so bilinear lookups at the
seams never blend in black. The avatar at step 0 is then the no-learning floor.
"""

from __future__ import annotations

import numpy as np

from morf.train.frames import FrameSet


def projected_colour_texture(frames: FrameSet, covered: np.ndarray, dilate: int = 4) -> np.ndarray:
    """(3, S, S) float32 colour texture in [0, 1] for a (S, S) atlas coverage ``covered``: the
    colour channels of the no-learning floor (:func:`morf.train.floor_texture.floor_texture`)."""
    from morf.train.floor_texture import floor_texture

    return np.ascontiguousarray(floor_texture(frames, covered, dilate)[0][:3])
