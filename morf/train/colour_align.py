"""Flow-aligned colour projection: the training frames warped onto one another before they are
averaged into the texture's colour channels.

The frames of a capture disagree by the body fit's error (a few pixels at the face), so the plain
projection (:func:`morf.train.inpaint.project_rgb_texture`) averages misaligned copies of every
detail into a ghosted blur. Each frame's rasterization already says which texel every pixel sees,
so the current projection seen from frame ``i`` is the texture sampled at frame ``i``'s UVs (no
rasterizing). Dense optical flow from that render to the real frame says where each texel's colour
really lies in that frame; the real frame warped by that flow (pixel ``p`` takes the colour at
``p + flow(p)``) holds, at ``p``, the colour of the texel ``p`` sees. Projecting the warped frames
again gives a texture whose frames agree, so the average keeps their detail. A few passes let the
consensus sharpen; each pass warps the ORIGINAL frames (one resampling, not a chain of them).

The flow is clamped to ``max_flow`` pixels (the fit's expected error): a longer flow is a wrong
match on a textureless or repeating patch, not a fit error. Pixels whose warped source would fall
outside the person keep their own colour, so the backdrop never leaks onto the body.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from morf.io.images import grey_uint8
from morf.train.frames import UV_SCALE, FrameSet
from morf.train.texel_splat import Projection

MAX_FLOW_SHARE = 0.01  # flow clamp as a share of the frame side: 6.4 px at 640 px, 2.6 px at 256 px
REGION_MARGIN = 16  # pixels around the person's box that the flow is estimated on


@dataclass(frozen=True)
class ColourAlignment:
    """What the alignment did.

    Fields:
        passes: projection passes after the first (0: the plain projection).
        max_flow: the flow clamp in pixels at the frames' resolution.
        flow_median, flow_p95: per pass, the median and 95th percentile of the flow's length in
            pixels over the projecting pixels of every frame (before the clamp).
    """

    passes: int
    max_flow: float
    flow_median: tuple[float, ...]
    flow_p95: tuple[float, ...]

    def describe(self) -> str:
        per_pass = ", ".join(f"{m:.2f}/{p:.2f}" for m, p in zip(self.flow_median, self.flow_p95))
        return (f"colour aligned by optical flow over {self.passes} pass(es), flow clamped to {self.max_flow:.1f} px "
                f"(median/95th percentile px per pass: {per_pass or 'none'})")


def sample_colour(rgb: np.ndarray, uv: np.ndarray, uv_mask: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: an (S, S, 3) colour texture sampled bilinearly at a frame's packed
    (H, W, 2) uint16 UVs, 0 outside ``uv_mask``. Texel (row, col) is centred at
    u = (col + 0.5) / S, v = 1 - (row + 0.5) / S, as the projection bins pixels."""
    size = rgb.shape[0]
    uvf = uv.astype(np.float32) / UV_SCALE
    mx = uvf[..., 0] * size - 0.5
    my = (1 - uvf[..., 1]) * size - 0.5
    out = cv2.remap(np.ascontiguousarray(rgb, np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out * uv_mask[..., None]


def frame_flow(render: np.ndarray, real: np.ndarray, region: np.ndarray, max_flow: float,
               dis=None) -> tuple[np.ndarray, np.ndarray]:
    """Dense flow from ``render`` to ``real`` inside ``region``: real(p + flow(p)) ~ render(p).

    Args:
        render, real: (H, W, 3) float in [0, 1]; region: (H, W) bool pixels to align (elsewhere
        the render is replaced by the real frame so the flow sees no false edges there).
    Returns:
        flow: (H, W, 2) float32 (dx, dy), clamped to ``max_flow`` px, 0 outside ``region``;
        length: (K,) float32 the unclamped flow's length at the K region pixels.
    """
    H, W = region.shape
    flow = np.zeros((H, W, 2), np.float32)
    if not region.any():
        return flow, np.zeros(0, np.float32)
    rows, cols = np.nonzero(region.any(1))[0], np.nonzero(region.any(0))[0]
    y0, y1 = max(rows[0] - REGION_MARGIN, 0), min(rows[-1] + REGION_MARGIN + 1, H)
    x0, x1 = max(cols[0] - REGION_MARGIN, 0), min(cols[-1] + REGION_MARGIN + 1, W)
    box = region[y0:y1, x0:x1]
    a = np.where(box[..., None], render[y0:y1, x0:x1], real[y0:y1, x0:x1])
    dis = dis or cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    f = dis.calc(grey_uint8(a), grey_uint8(real[y0:y1, x0:x1]), None)
    length = np.linalg.norm(f, axis=-1)
    scale = np.minimum(1.0, max_flow / np.maximum(length, 1e-6))
    flow[y0:y1, x0:x1] = f * scale[..., None] * box[..., None]
    return flow, length[box].astype(np.float32)


def warp_frame(image: np.ndarray, mask: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8: ``image`` with pixel p taking the colour at p + flow(p); pixels whose
    source touches the outside of ``mask`` (the person) keep their own colour."""
    H, W = mask.shape
    gx, gy = np.meshgrid(np.arange(W, dtype=np.float32), np.arange(H, dtype=np.float32))
    mx, my = gx + flow[..., 0], gy + flow[..., 1]
    warped = cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    inside = cv2.remap(mask.astype(np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    keep = inside > 0.999
    return np.where(keep[..., None], warped, image)


def align_frames(frames: FrameSet, rgb: np.ndarray, max_flow: float,
                 min_facing: float = 0.3) -> tuple[FrameSet, np.ndarray]:
    """``frames`` with every image warped onto the (S, S, 3) colour texture ``rgb`` as seen from it.

    The flow is estimated where the frame projects into the texture (person mask, mesh coverage,
    facing >= ``min_facing``). Returns the warped FrameSet (everything but the images shared) and
    the (K,) unclamped flow lengths over all frames' projecting pixels.
    """
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    images = np.empty_like(frames.images)
    lengths = []
    min_cos = int(round(min_facing * 255))
    for i in range(frames.num_frames):
        region = frames.uv_mask[i] & frames.masks[i] & (frames.facing[i] >= min_cos)
        real = frames.images[i].astype(np.float32) / 255
        render = sample_colour(rgb, frames.uv[i], frames.uv_mask[i])
        flow, length = frame_flow(render, real, region, max_flow, dis)
        images[i] = warp_frame(frames.images[i], frames.masks[i], flow)
        lengths.append(length)
    return dataclasses.replace(frames, images=images), np.concatenate(lengths)


def aligned_floor_texture(frames: FrameSet, covered: np.ndarray, passes: int, dilate: int = 4,
                          min_facing: float = 0.3, how: Projection = Projection(),
                          max_flow: float | None = None) -> tuple[np.ndarray, np.ndarray, ColourAlignment]:
    """:func:`morf.train.floor_texture.floor_texture` from frames aligned to their own projection.

    Pass 0 is the plain projection; each of ``passes`` further passes warps the original frames
    onto the previous pass's texture (:func:`align_frames`) and projects them again with the same
    projection ``how`` (:func:`morf.train.inpaint.project_rgb_texture`).
    ``max_flow`` (default ``MAX_FLOW_SHARE`` of the frame side) clamps the flow.
    Returns the (4, S, S) float32 texture, the (S, S) seen map and a :class:`ColourAlignment`.
    """
    from morf.train.floor_texture import floor_texture

    if passes < 0:
        raise ValueError(f"passes must be >= 0, got {passes}")
    max_flow = MAX_FLOW_SHARE * frames.resolution if max_flow is None else float(max_flow)
    texture, seen = floor_texture(frames, covered, dilate, min_facing, how)
    medians, p95s = [], []
    for _ in range(passes):
        warped, length = align_frames(frames, texture[:3].transpose(1, 2, 0), max_flow, min_facing)
        medians.append(round(float(np.median(length)), 3) if length.size else 0.0)
        p95s.append(round(float(np.percentile(length, 95)), 3) if length.size else 0.0)
        texture, seen = floor_texture(warped, covered, dilate, min_facing, how)
    return texture, seen, ColourAlignment(passes, round(max_flow, 3), tuple(medians), tuple(p95s))
