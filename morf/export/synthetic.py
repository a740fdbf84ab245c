"""A synthetic exported avatar: spectral neural texture + random-init renderer.

For benchmarks on a fresh clone and for tests: playback speed does not depend on what the
texture and renderer learned, only on their sizes. Needs torch and the body model.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from morf.export.export_avatar import ExportConfig, View, export_avatar
from morf.raster.texture_quant import sinusoid_texture


def turntable_views(num: int, size: int, seed: int = 0, num_bones: int = 104, pose_scale: float = 0.15) -> list[View]:
    """``num`` views of the body turning in place (yaw on the root) with small random joint angles."""
    from morf.raster.camera_paths import front_camera

    rng = np.random.default_rng(seed)
    views = []
    for i in range(num):
        rot = (rng.normal(size=(num_bones, 3)) * pose_scale).astype(np.float32)
        rot[0] = (0.0, 0.0, 2 * np.pi * i / max(num, 1))
        views.append(View(rot, np.zeros(3, np.float32), front_camera(size)))
    return views


def build_synthetic_avatar(out_dir: str | Path, body_model=None, renderer_cfg=None, texture_size: int = 256,
                           image_size: int = 128, calibration_views: int = 6, heldout_views: int = 2,
                           input_layout: str = "nhwc", seed: int = 0, renderer=None, texture=None,
                           playback_zoom: float = 0.0) -> dict:
    """Export a synthetic avatar to ``out_dir``; returns its manifest.

    ``renderer_cfg``: a :class:`morf.avatar.renderer.RendererConfig` (default: the "cpu" training
    preset's renderer). ``renderer`` / ``texture`` replace the random ones (tests use a renderer
    whose mask follows the coverage, so the person's silhouette is known). ``playback_zoom``: as
    :class:`~morf.export.export_avatar.ExportConfig`'s.
    """
    import torch

    from morf.avatar.renderer import UNetRenderer

    if renderer_cfg is None:
        from morf.train.config import preset

        renderer_cfg = preset("cpu").renderer
    if body_model is None:
        from morf.body import load_body_model

        body_model = load_body_model("anny")
    torch.manual_seed(seed)
    renderer = UNetRenderer(renderer_cfg).eval() if renderer is None else renderer
    texture = sinusoid_texture(renderer_cfg.in_channels, texture_size, seed) if texture is None else texture
    views = turntable_views(calibration_views + heldout_views, image_size, seed, len(body_model.bone_names))
    cfg = ExportConfig(input_layout=input_layout, playback_zoom=playback_zoom, extra={"synthetic": True})
    return export_avatar(out_dir, texture=texture, renderer=renderer, body_model=body_model,
                         shape=body_model.default_shape(), calibration=views[:calibration_views],
                         heldout=views[calibration_views:], cfg=cfg)


def coverage_renderer():
    """A stand-in renderer whose mask is the body's coverage (texture channel 0 set to 1) and whose
    colour comes from channels 1-3: renders of it are checkable by eye and by tests. Pair it with a
    texture from :func:`coverage_texture`."""
    import torch

    class CoverageRenderer(torch.nn.Module):
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

    return CoverageRenderer()


def coverage_texture(size: int = 64, seed: int = 4):
    """(16, size, size) spectral texture with channel 0 = 1 (the coverage channel)."""
    tex = sinusoid_texture(16, size, seed=seed) * 0.5
    tex[0] = 1.0
    return tex
