import math

import numpy as np
import torch

from morf.avatar.discriminator import MultiScaleDiscriminator
from morf.avatar.losses import (dice_loss, feature_matching_loss, gan_discriminator_loss, gan_generator_loss,
                                l1_loss, offset_l2, tv_loss)
from morf.avatar.metrics import psnr, ssim, ssim_map, temporal_flicker


def test_loss_known_values():
    a, b = torch.zeros(1, 3, 4, 4), torch.full((1, 3, 4, 4), 0.5)
    assert math.isclose(float(l1_loss(a, b)), 0.5)
    w = torch.zeros(1, 1, 4, 4)
    w[..., :2, :] = 1
    b2 = b.clone()
    b2[..., 2:, :] = 9  # ignored by the weight
    assert math.isclose(float(l1_loss(a, b2, w)), 0.5)
    m = torch.ones(1, 1, 4, 4)
    assert float(dice_loss(m, m)) < 1e-6
    assert math.isclose(float(dice_loss(torch.zeros_like(m), m, eps=0)), 1.0)
    x = torch.zeros(1, 1, 2, 2)
    x[..., 1] = 1  # one vertical edge: dx = 1 everywhere, dy = 0
    assert math.isclose(float(tv_loss(x)), 1.0)
    assert math.isclose(float(offset_l2(torch.full((1, 2, 3, 3), 0.5))), 0.5)
    z = [torch.zeros(1, 1, 2, 2)]
    assert math.isclose(float(gan_generator_loss(z)), math.log(2), rel_tol=1e-6)
    assert math.isclose(float(gan_discriminator_loss(z, z)), 2 * math.log(2), rel_tol=1e-6)


def test_feature_matching_and_discriminator_shapes():
    d = MultiScaleDiscriminator(4, width=4, layers=2, scales=2)
    x = torch.rand(2, 4, 32, 32)
    out = d(x)
    assert len(out) == 2 and out[0][-1].shape[1] == 1
    assert float(feature_matching_loss(out, out).detach()) == 0.0


def test_psnr_known():
    a = torch.zeros(1, 3, 8, 8)
    assert math.isclose(psnr(a, a + 0.1), 20.0, rel_tol=1e-5)
    mask = torch.zeros(1, 8, 8, dtype=torch.bool)
    mask[:, :4] = True
    b = a.clone()
    b[..., 4:, :] = 1.0  # error only outside the mask
    b[..., :4, :] = 0.01
    assert math.isclose(psnr(a, b, mask), 40.0, rel_tol=1e-4)
    assert psnr(a, a) == float("inf")


def test_ssim_identical_constant_and_noise():
    torch.manual_seed(0)
    img = torch.rand(1, 3, 32, 32)
    assert math.isclose(ssim(img, img), 1.0, abs_tol=1e-12)
    # two constant images c1, c2: SSIM = (2 c1 c2 + C1) / (c1^2 + c2^2 + C1)
    c1, c2, C1 = 0.2, 0.6, 0.01 ** 2
    expected = (2 * c1 * c2 + C1) / (c1 ** 2 + c2 ** 2 + C1)
    assert math.isclose(ssim(torch.full((1, 1, 16, 16), c1), torch.full((1, 1, 16, 16), c2)), expected, rel_tol=1e-5)
    assert ssim_map(img, img).shape == (1, 3, 22, 22)
    # independent noise added to a constant image: the structure term collapses
    noisy = (0.5 + 0.1 * torch.randn(1, 1, 64, 64)).clamp(0, 1)
    s = ssim(torch.full_like(noisy, 0.5), noisy)
    # expected ~ C2 / (sigma^2 + C2) with sigma^2 the windowed noise variance (~0.01)
    C2 = 0.03 ** 2
    assert abs(s - C2 / (0.01 + C2)) < 0.03


def test_ssim_masked_ignores_outside():
    a = torch.rand(1, 1, 40, 40)
    b = a.clone()
    b[..., :, 30:] = torch.rand(1, 1, 40, 10)
    m = torch.zeros(1, 40, 40)
    m[:, :, :15] = 1
    assert math.isclose(ssim(a, b, m), 1.0, abs_tol=1e-9)
    assert ssim(a, b) < 0.99


def test_temporal_flicker():
    gt = torch.rand(5, 3, 8, 8)
    assert temporal_flicker(gt + 0.2, gt) < 1e-6  # a constant offset does not flicker
    flick = gt.clone()
    flick[1::2] += 0.1
    assert math.isclose(temporal_flicker(flick, gt), 0.1, rel_tol=1e-4)
    assert np.isnan(temporal_flicker(gt[:1], gt[:1]))
