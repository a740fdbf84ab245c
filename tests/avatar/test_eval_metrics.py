"""Evaluation metrics: SSIM against a plain reference, compositing, background colour."""

import math

import torch
import torch.nn.functional as F

from morf.avatar.metrics import background_colour, composite_over, psnr, ssim, ssim_map


def _ssim_reference(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Plain SSIM (Wang et al. 2004): 2-D 11x11 gaussian (sigma 1.5) as one float64 grouped convolution."""
    x, y = x.double(), y.double()
    C = x.shape[1]
    t = torch.arange(11, dtype=torch.float64) - 5
    g = torch.exp(-t ** 2 / (2 * 1.5 ** 2))
    g = g / g.sum()
    w = (g[:, None] * g[None, :]).expand(C, 1, 11, 11)

    def blur(a):
        return F.conv2d(a, w, groups=C)

    mx, my = blur(x), blur(y)
    sxx, syy, sxy = blur(x * x) - mx ** 2, blur(y * y) - my ** 2, blur(x * y) - mx * my
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    return ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx ** 2 + my ** 2 + c1) * (sxx + syy + c2))


def test_ssim_matches_plain_reference():
    g = torch.Generator().manual_seed(0)
    a = F.avg_pool2d(torch.rand(2, 3, 52, 60, generator=g), 3, 1, 1)  # some spatial structure
    b = (a + 0.05 * torch.randn(a.shape, generator=g)).clamp(0, 1)
    ref = _ssim_reference(b, a)
    assert torch.allclose(ssim_map(b, a), ref, atol=1e-10)
    assert math.isclose(ssim(b, a), float(ref.mean()), rel_tol=1e-9)


def test_background_colour_is_the_median_outside_the_person():
    img = torch.full((2, 3, 8, 8), 0.25)
    img[:, 1] = 0.5
    mask = torch.zeros(2, 1, 8, 8)
    mask[..., 2:6, 2:6] = 1
    img[..., 2:6, 2:6] = 0.9  # the person does not count
    img[0, :, 0, 0] = 1.0  # a single outlier does not move the median
    assert torch.allclose(background_colour(img, mask), torch.tensor([0.25, 0.5, 0.25]))


def test_composite_over_matches_player_formula():
    rgb = torch.tensor([0.3, 0.2, 0.1]).view(1, 3, 1, 1).expand(1, 3, 2, 2).clone()
    alpha = torch.tensor([[1.0, 0.5], [0.0, 0.9]]).view(1, 1, 2, 2)
    bg = torch.tensor([0.4, 0.6, 1.0])
    out = composite_over(rgb * alpha, alpha, bg)
    expected = (rgb * alpha + (1 - alpha) * bg.view(1, 3, 1, 1)).clamp(0, 1)
    assert torch.allclose(out, expected)
    assert torch.allclose(out[0, :, 1, 0], bg)  # alpha 0: pure background


def test_background_leak_costs_ssim_on_black_but_not_on_grey():
    """Why evaluation composites over the capture's backdrop: a 0.01 leak on black halves SSIM."""
    person = torch.zeros(1, 1, 32, 32)
    gt = torch.zeros(1, 3, 32, 32)
    pred = gt + 0.01 * (1 - person)  # the render leaks 0.01 everywhere outside the person
    assert ssim(pred, gt) < 0.6
    grey = torch.tensor([0.48, 0.49, 0.5])
    on_grey = ssim(composite_over(pred, person, grey), composite_over(gt, person, grey))
    assert on_grey > 0.99
    assert math.isclose(psnr(pred, gt), 40.0, rel_tol=1e-4)  # PSNR is unaffected by the backdrop
