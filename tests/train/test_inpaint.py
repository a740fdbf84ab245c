import numpy as np
import torch

from morf.avatar.renderer import RendererConfig, UNetRenderer
from morf.train.inpaint import close_seen, fill_unseen, finetune_unseen, project_rgb_texture


def _train_conftest():
    """This folder's conftest as a module (``import conftest`` finds whichever folder's came first)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("train_conftest", Path(__file__).with_name("conftest.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_projection_averages_colours_of_seen_texels(frames_factory):
    fs = frames_factory(n=3, res=32)
    rgb, seen = project_rgb_texture(fs, 32)
    assert rgb.shape == (32, 32, 3) and seen.dtype == bool
    assert 0.1 < seen.mean() < 0.9  # the discs show only part of the atlas
    # every frame was made by sampling one texture, so the projected colours match it up to
    # bilinear blur and nearest-texel splatting
    checker_texture = _train_conftest().checker_texture

    ref = checker_texture(32).permute(1, 2, 0).numpy()
    assert np.abs(rgb[seen] - ref[seen]).mean() < 0.12


def test_fill_and_finetune_only_touch_unseen_texels():
    torch.manual_seed(0)
    C, T = 4, 16
    seen = np.zeros((T, T), bool)
    seen[:, :8] = True  # left half of the atlas was seen in training
    covered = np.ones((T, T), bool)
    rgb = np.zeros((T, T, 3), np.float32)
    rgb[:, :8] = [0.8, 0.2, 0.1]
    filled = fill_unseen(rgb, seen, covered)
    assert np.allclose(filled[:, :8], rgb[:, :8]) and filled[:, 8:].mean() > 0.05  # colour flowed in
    assert close_seen(seen).sum() >= seen.sum()

    renderer = UNetRenderer(RendererConfig(in_channels=C, width=4, depth=1, stem=2, skip_hidden=4))
    ren_before = [p.clone() for p in renderer.parameters()]
    tex = torch.randn(C, T, T)
    # pseudo views: every pixel looks at some texel across the whole atlas
    yy, xx = torch.meshgrid(torch.linspace(0.02, 0.98, 16), torch.linspace(0.02, 0.98, 16), indexing="ij")
    uv = torch.stack([xx, yy], -1)[None].repeat(3, 1, 1, 1)
    uvm = torch.ones(3, 16, 16, dtype=torch.bool)
    new, hist = finetune_unseen(tex, renderer, uv, uvm, torch.from_numpy(filled).permute(2, 0, 1),
                                torch.from_numpy(seen), steps=15, lr=0.05)
    assert torch.equal(new[:, :, :8], tex[:, :, :8])  # seen texels exactly unchanged
    assert not torch.allclose(new[:, :, 9:], tex[:, :, 9:])
    assert hist[-1] < hist[0]
    assert all(torch.equal(a, b) for a, b in zip(ren_before, renderer.parameters()))
    assert all(p.requires_grad for p in renderer.parameters())  # flags restored
