"""The image terms of the training objective: on black, or over a random backdrop colour."""

import pytest
import torch

from morf.avatar.model import AvatarOutput
from morf.errors import InputError
from morf.train.config import preset
from morf.train.frames import Batch
from morf.train.objective import composited, generator_losses


def _batch(image, mask):
    B, _, h, w = image.shape
    return Batch(image, mask, torch.zeros(B, h, w, 2), torch.ones(B, h, w, dtype=torch.bool),
                 torch.zeros(B, 1, 3), torch.arange(B))


def _output(rgb, mask_prob):
    logit = torch.logit(mask_prob.clamp(1e-6, 1 - 1e-6))
    return AvatarOutput(rgb=rgb, mask_logit=logit, features=torch.zeros_like(rgb), offsets=None)


def _edge_case():
    """One person pixel (blue) and one backdrop pixel the render calls person, coloured black:
    the dark band beside a body."""
    image = torch.zeros(2, 3, 1, 2)
    image[:, :, 0, 0] = torch.tensor([0.2, 0.3, 0.6])
    mask = torch.zeros(2, 1, 1, 2)
    mask[:, :, 0, 0] = 1.0
    rgb = image * mask  # the person pixel right, the backdrop pixel black (premultiplied: 0)
    prob = torch.ones(2, 1, 1, 2)  # ... but inside the mask
    return _batch(image, mask), _output(rgb, prob)


def test_black_backdrop_does_not_see_a_dark_pixel_inside_the_mask():
    batch, out = _edge_case()
    cfg = preset("tiny", "morf").replace(w_ssim=0.0, loss_background="black")
    assert float(generator_losses(cfg, out, batch)["l1"]) == pytest.approx(0.0, abs=1e-6)


def test_random_backdrop_charges_the_dark_pixel_inside_the_mask():
    batch, out = _edge_case()
    cfg = preset("tiny", "morf").replace(w_ssim=0.0, loss_background="random")
    torch.manual_seed(0)
    l1 = float(generator_losses(cfg, out, batch)["l1"])
    assert l1 > 0.05  # the backdrop pixel shows black where the frame shows the backdrop colour


def test_composite_is_the_players():
    torch.manual_seed(1)
    rgb, prob = torch.rand(3, 3, 4, 4), torch.rand(3, 1, 4, 4)
    target, mask = torch.rand(3, 3, 4, 4), (torch.rand(3, 1, 4, 4) > 0.5).float()
    out = _output(rgb, prob)
    torch.manual_seed(2)
    a, b = composited(out, target, mask)
    torch.manual_seed(2)
    colour = torch.rand(3, 3, 1, 1)
    assert torch.allclose(a, rgb + (1 - out.mask) * colour)
    assert torch.allclose(b, target + (1 - mask) * colour)


def test_unknown_loss_background_is_refused():
    with pytest.raises(InputError, match="loss_background"):
        preset("tiny", "morf").replace(loss_background="white")
