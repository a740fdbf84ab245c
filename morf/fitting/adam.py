"""Adam for the fit's handful of parameter tensors, without ``torch.optim``.

``torch.optim``'s optimizers import torch's compiler (``torch._dynamo``, sympy, FX) the first
time a parameter group is added: 0.8-1.3 s on two CPU cores, a tenth of fitting a two-second
clip. The fit optimises a few tensors with plain Adam (no weight decay, no AMSGrad), which is
these few lines; the test checks them against ``torch.optim.Adam`` step for step.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import torch


class Adam:
    """Adam (Kingma & Ba 2015) with bias correction, as ``torch.optim.Adam`` with its defaults.

    Args:
        params: tensors, or parameter groups ``{"params": [...], "lr": float}``.
        lr: learning rate of groups that do not name their own.
    """

    def __init__(self, params: Iterable, lr: float = 1e-3, betas: tuple[float, float] = (0.9, 0.999),
                 eps: float = 1e-8):
        params = list(params)
        if params and not isinstance(params[0], dict):
            params = [{"params": params}]
        self.param_groups = [{"params": list(g["params"]), "lr": float(g.get("lr", lr))} for g in params]
        self.betas = betas
        self.eps = eps
        self._state: dict[int, list] = {}  # id(param) -> [steps taken, first moment, second moment]

    def zero_grad(self, set_to_none: bool = True) -> None:
        for group in self.param_groups:
            for p in group["params"]:
                if p.grad is None:
                    continue
                if set_to_none:
                    p.grad = None
                else:
                    p.grad.zero_()

    @torch.no_grad()
    def step(self) -> None:
        b1, b2 = self.betas
        for group in self.param_groups:
            for p in group["params"]:
                if p.grad is None:
                    continue
                state = self._state.get(id(p))
                if state is None:
                    state = self._state[id(p)] = [0, torch.zeros_like(p), torch.zeros_like(p)]
                state[0] += 1
                t, m, v = state
                c1 = 1.0 - b1 ** t
                c2 = math.sqrt(1.0 - b2 ** t)
                m.lerp_(p.grad, 1.0 - b1)
                v.mul_(b2).addcmul_(p.grad, p.grad, value=1.0 - b2)
                p.addcdiv_(m, (v.sqrt() / c2).add_(self.eps), value=-group["lr"] / c1)
