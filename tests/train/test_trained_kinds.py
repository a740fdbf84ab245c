"""avatar.pt records its renderer's kind; files written before the kind existed load as U-Nets."""

import torch

from morf.avatar.renderer import RendererConfig, UNetRenderer
from morf.train.config import preset
from morf.train.trained_avatar import load_trained_avatar, save_trained_avatar


def test_files_without_a_renderer_kind_load_as_unet(tmp_path):
    cfg = preset("tiny", "stylepeople", device="cpu")
    renderer = UNetRenderer(cfg.renderer)
    path = tmp_path / "avatar.pt"
    save_trained_avatar(path, torch.zeros(8, 16, 16), renderer, cfg.to_dict(), None, None)
    payload = torch.load(path, weights_only=True)
    assert payload["renderer_kind"] == "unet"
    del payload["renderer_kind"]  # as written before the key existed
    torch.save(payload, path)
    av = load_trained_avatar(path)
    assert isinstance(av.renderer, UNetRenderer) and av.renderer.cfg == RendererConfig(**payload["renderer_config"])
    rgb, alpha = av.render(torch.rand(1, 16, 16, 2), torch.ones(1, 16, 16, dtype=torch.bool))
    assert rgb.shape == (1, 3, 16, 16) and alpha.shape == (1, 1, 16, 16)
