"""A tiny exported avatar whose renderer's mask follows the mesh coverage, so renders are checkable."""

from types import SimpleNamespace

import numpy as np
import pytest
import torch

from morf.export.texture_quant import spectral_texture

SIZE = 128


class CoverageRenderer(torch.nn.Module):
    """Stand-in renderer: mask from texture channel 0 (1 on the body), colour from channels 1-3."""

    cfg = SimpleNamespace(in_channels=16, multiple=8)

    def __init__(self):
        super().__init__()
        self.conv = torch.nn.Conv2d(16, 4, 1)
        with torch.no_grad():
            self.conv.weight.zero_()
            self.conv.bias.zero_()
            for c in range(3):
                self.conv.weight[c, c + 1] = 2.0
            self.conv.weight[3, 0] = 40.0
            self.conv.bias[3] = -8.0

    def forward(self, x):
        h = self.conv(x)
        m = h[:, 3:]
        return torch.cat([torch.sigmoid(h[:, :3]) * torch.sigmoid(m), m], 1)


@pytest.fixture(scope="session")
def tiny_avatar(tmp_path_factory, body_model):
    from morf.export.synthetic import build_synthetic_avatar

    tex = spectral_texture(16, 64, seed=4) * 0.5
    tex[0] = 1.0  # coverage channel
    out = tmp_path_factory.mktemp("avatar") / "avatar"
    build_synthetic_avatar(out, body_model=body_model, renderer=CoverageRenderer(), texture=tex,
                           image_size=64, calibration_views=3, heldout_views=1,
                           renderer_cfg=SimpleNamespace(in_channels=16))
    return out


@pytest.fixture()
def still_pose():
    rng = np.random.default_rng(7)
    rot = (rng.normal(size=(104, 3)) * 0.1).astype(np.float32)
    rot[0] = (0, 0, 0.4)
    return rot, np.array([0.02, 0.0, 0.0], np.float32)
