"""Fixtures for the training tests: tiny synthetic frames (no body model, no OpenGL)."""

from __future__ import annotations

import numpy as np
import torch

from morf.avatar.texture import sample_texture
from morf.train.frames import FrameSet


def checker_texture(size: int = 32) -> torch.Tensor:
    """(3, size, size) colourful checkerboard in [0, 1]."""
    y, x = np.mgrid[0:size, 0:size]
    c = ((x // 4 + y // 4) % 2).astype(np.float32)
    return torch.from_numpy(np.stack([c, 0.3 + 0.4 * x / size, 1 - c * 0.5 - 0.3 * y / size]).astype(np.float32))


def synthetic_frames(n: int = 6, res: int = 32, joints: int = 104, seed: int = 0) -> FrameSet:
    """n frames: a disc of 'body' whose UVs slide a little per frame, coloured by checker_texture."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:res, 0:res].astype(np.float32) + 0.5
    uvs, masks = [], []
    for i in range(n):
        cx, cy = res / 2 + rng.uniform(-2, 2), res / 2 + rng.uniform(-2, 2)
        m = (xx - cx) ** 2 + (yy - cy) ** 2 < (0.4 * res) ** 2
        u = np.clip((xx - cx) / res + 0.5 + 0.02 * i, 0, 1)
        v = np.clip(1 - ((yy - cy) / res + 0.5), 0, 1)
        uvs.append(np.stack([u, v], -1))
        masks.append(m)
    uv = np.stack(uvs)
    mask = np.stack(masks)
    tex = checker_texture()
    rgb = sample_texture(tex, torch.from_numpy(uv), torch.from_numpy(mask))
    images = (rgb.permute(0, 2, 3, 1).numpy() * 255).round().astype(np.uint8)
    rot = rng.normal(0, 0.1, size=(n, joints, 3)).astype(np.float32)
    return FrameSet.from_float(images, mask, uv, mask, rot)


import pytest  # noqa: E402


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    """Tiny tensors gain nothing from a second thread, and on a loaded 2-core machine OpenMP's
    barrier waits made these tests 10-50x slower (a 60-step tiny run: 1.7 s alone, 116 s beside
    another training job)."""
    prev = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(prev)


@pytest.fixture
def frames_factory():
    return synthetic_frames
