"""The fit's Adam against torch.optim.Adam, step for step."""

import torch

from morf.fitting.adam import Adam


def _problem(seed):
    g = torch.Generator().manual_seed(seed)
    a = torch.randn(5, 3, generator=g).requires_grad_(True)
    b = torch.randn(7, generator=g).requires_grad_(True)
    target = torch.randn(5, 3, generator=g)
    return a, b, target


def _loss(a, b, target, it):
    loss = ((a - target) ** 2).sum() + (a.sin().sum() * 0.1)
    if it % 3 != 2:  # b gets no gradient every third step: its own step count must lag
        loss = loss + (b ** 4).sum() * 0.5
    return loss


def test_matches_torch_adam_over_groups_and_missing_grads():
    a1, b1, t = _problem(0)
    a2, b2 = a1.detach().clone().requires_grad_(True), b1.detach().clone().requires_grad_(True)
    ours = Adam([{"params": [a1], "lr": 0.05}, {"params": [b1], "lr": 0.01}])
    ref = torch.optim.Adam([{"params": [a2], "lr": 0.05}, {"params": [b2], "lr": 0.01}])
    for it in range(40):
        for opt, a, b in ((ours, a1, b1), (ref, a2, b2)):
            opt.zero_grad(set_to_none=True)
            _loss(a, b, t, it).backward()
            opt.step()
        torch.testing.assert_close(a1, a2, rtol=1e-5, atol=1e-6)
        torch.testing.assert_close(b1, b2, rtol=1e-5, atol=1e-6)
    assert not torch.equal(a1, _problem(0)[0])  # it moved


def test_plain_parameter_list_and_zero_grad_in_place():
    a, _, t = _problem(1)
    opt = Adam([a], lr=0.1)
    ((a - t) ** 2).sum().backward()
    opt.step()
    opt.zero_grad(set_to_none=False)
    assert a.grad is not None and float(a.grad.abs().sum()) == 0.0
