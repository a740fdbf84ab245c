"""Training frames in memory: images, masks and their precomputed rasterizations.

A :class:`FrameSet` is built once per project and fits version (see :mod:`morf.train.data`) so
the training loop never rasterizes; :meth:`FrameSet.batch` turns a few of them into tensors.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

UV_SCALE = 65535.0  # UVs are stored as uint16 fixed point: 1.5e-5 precision, 4x smaller than float32


def pack_uv(uv: np.ndarray) -> np.ndarray:
    """Float UVs in [0, 1] (clipped) -> the uint16 fixed point a :class:`FrameSet` stores."""
    return np.round(np.clip(uv, 0, 1) * UV_SCALE).astype(np.uint16)


@dataclass(frozen=True)
class FrameSet:
    """N training frames at the working resolution (H = W = resolution).

    Fields:
        images: (N, H, W, 3) uint8 RGB.
        masks: (N, H, W) bool person masks.
        uv: (N, H, W, 2) uint16 rasterized UVs (v up) times ``UV_SCALE``.
        uv_mask: (N, H, W) bool mesh coverage.
        facing: (N, H, W) uint8, |cos| between the surface normal and the view ray times 255.
        rotvecs: (N, J, 3) float32 body pose per frame.
        frame_ids: (N,) int64 frame numbers in the project.
    """

    images: np.ndarray
    masks: np.ndarray
    uv: np.ndarray
    uv_mask: np.ndarray
    facing: np.ndarray
    rotvecs: np.ndarray
    frame_ids: np.ndarray

    def __post_init__(self):
        N = self.images.shape[0]
        for name in ("masks", "uv", "uv_mask", "facing", "rotvecs", "frame_ids"):
            if getattr(self, name).shape[0] != N:
                raise ValueError(f"FrameSet.{name} has {getattr(self, name).shape[0]} frames, images {N}")
        if N == 0:
            raise ValueError("FrameSet needs at least one frame")

    @property
    def num_frames(self) -> int:
        return int(self.images.shape[0])

    @property
    def resolution(self) -> int:
        return int(self.images.shape[1])

    @staticmethod
    def from_float(images, masks, uv, uv_mask, rotvecs, facing=None, frame_ids=None) -> "FrameSet":
        """Build from float UVs (N, H, W, 2) in [0, 1] (and defaults for the rest); for tests and tools."""
        uv = np.asarray(uv, np.float32)
        N = uv.shape[0]
        return FrameSet(
            images=np.asarray(images, np.uint8), masks=np.asarray(masks, bool),
            uv=pack_uv(uv), uv_mask=np.asarray(uv_mask, bool),
            facing=np.full(uv.shape[:3], 255, np.uint8) if facing is None else np.asarray(facing, np.uint8),
            rotvecs=np.asarray(rotvecs, np.float32),
            frame_ids=np.arange(N, dtype=np.int64) if frame_ids is None else np.asarray(frame_ids, np.int64))

    def subset(self, indices) -> "FrameSet":
        """The frames at positions ``indices`` of this set, in that order."""
        idx = np.asarray(indices, dtype=np.int64)
        return FrameSet(self.images[idx], self.masks[idx], self.uv[idx], self.uv_mask[idx], self.facing[idx],
                        self.rotvecs[idx], self.frame_ids[idx])

    def batch(self, indices, crop: int = 0, rng: np.random.Generator | None = None, device="cpu",
              origins: tuple[np.ndarray, np.ndarray] | None = None) -> "Batch":
        """Tensors for frames ``indices`` (positions in this set), optionally a ``crop``-pixel crop
        each: at random, or with its top-left corner at ``origins`` ((B,) rows, (B,) columns, inside
        the image; :func:`morf.train.detail.crop_origins`)."""
        idx = np.asarray(indices, dtype=np.int64)
        R = self.resolution
        if crop and crop < R and origins is not None:
            sl = [(slice(int(y), int(y) + crop), slice(int(x), int(x) + crop)) for y, x in zip(*origins)]
        elif crop and crop < R:
            rng = rng or np.random.default_rng()
            ys = rng.integers(0, R - crop + 1, size=len(idx))
            xs = rng.integers(0, R - crop + 1, size=len(idx))
            sl = [(slice(y, y + crop), slice(x, x + crop)) for y, x in zip(ys, xs)]
        else:
            sl = [(slice(None), slice(None))] * len(idx)

        def take(a):
            return np.stack([a[i][s] for i, s in zip(idx, sl)])

        img = torch.from_numpy(take(self.images)).to(device).permute(0, 3, 1, 2).float() / 255
        return Batch(
            image=img,
            mask=torch.from_numpy(take(self.masks)).to(device).float().unsqueeze(1),
            uv=torch.from_numpy(take(self.uv).astype(np.float32) / UV_SCALE).to(device),
            uv_mask=torch.from_numpy(take(self.uv_mask)).to(device),
            rotvecs=torch.from_numpy(self.rotvecs[idx]).to(device),
            index=torch.from_numpy(idx).to(device))


@dataclass(frozen=True)
class Batch:
    """One training batch (B images of h x w).

    Fields:
        image: (B, 3, h, w) float RGB in [0, 1]; mask: (B, 1, h, w) float person mask.
        uv: (B, h, w, 2) float UVs; uv_mask: (B, h, w) bool mesh coverage.
        rotvecs: (B, J, 3) pose; index: (B,) long positions in the FrameSet (= latent ids).
    """

    image: torch.Tensor
    mask: torch.Tensor
    uv: torch.Tensor
    uv_mask: torch.Tensor
    rotvecs: torch.Tensor
    index: torch.Tensor
