"""A tiny exported avatar whose renderer's mask follows the mesh coverage, so renders are checkable."""

from types import SimpleNamespace

import numpy as np
import pytest


SIZE = 128


@pytest.fixture(scope="session")
def tiny_avatar(tmp_path_factory, body_model):
    from morf.export.synthetic import build_synthetic_avatar, coverage_renderer, coverage_texture

    out = tmp_path_factory.mktemp("avatar") / "avatar"
    build_synthetic_avatar(out, body_model=body_model, renderer=coverage_renderer(), texture=coverage_texture(),
                           image_size=64, calibration_views=3, heldout_views=1,
                           renderer_cfg=SimpleNamespace(in_channels=16))
    return out
