"""Import Anny without paying for torch's compiler.

Anny imports ``roma``, and ``roma.mappings`` wraps two autograd Functions in
``torch._dynamo.disable(...)`` at import time. That attribute access makes torch import its whole
compiler stack (``torch._dynamo``, sympy, the FX symbolic shapes), 1.3-1.4 s on two CPU cores,
paid by every command that loads the body model. MoRF Studio never runs ``torch.compile``, and
``disable`` only changes how those two Functions behave inside a compiled graph.

So while Anny is imported, and only if torch's compiler is not loaded yet, ``torch._dynamo``
resolves to a small stand-in whose ``disable`` returns the function unchanged. The stand-in is
removed right after, so any later ``torch._dynamo`` access imports the real module as usual.

The same stack is reached once more when Anny first builds a rest model: ``roma``'s rigid
transforms call ``torch.broadcast_shapes``, whose reference implementation imports the FX symbolic
shapes and sympy (0.35-0.4 s) to compare sizes that are plain integers here. ``roma.transforms``
therefore sees torch through a view whose ``broadcast_shapes`` answers integer shapes itself and
hands anything else (symbolic sizes) to torch.

``MORF_FULL_TORCH_IMPORT=1`` turns both off.
"""

from __future__ import annotations

import os
import sys
import types


def _stand_in() -> types.ModuleType:
    module = types.ModuleType("torch._dynamo")

    def disable(fn=None, recursive=True, **kwargs):
        if fn is None:
            return lambda f: f
        return fn

    module.disable = disable
    module.is_compiling = lambda: False
    return module


def broadcast_shapes(*shapes):
    """``torch.broadcast_shapes`` for shapes of plain ints (anything else goes to torch)."""
    import torch

    dims = []
    for s in shapes:
        s = (s,) if type(s) is int else s
        if not isinstance(s, (tuple, list, torch.Size)) or any(type(d) is not int for d in s):
            return torch.broadcast_shapes(*shapes)
        dims.append(s)
    out = [1] * max((len(s) for s in dims), default=0)
    for s in dims:
        for i, d in enumerate(s, start=len(out) - len(s)):
            if d < 0:
                return torch.broadcast_shapes(*shapes)  # torch's own error message
            if d != 1:
                if out[i] != 1 and out[i] != d:
                    return torch.broadcast_shapes(*shapes)  # raises: not broadcastable
                out[i] = d
    return torch.Size(out)


def _torch_view(torch) -> types.ModuleType:
    """A module that is ``torch`` but for :func:`broadcast_shapes`."""
    view = types.ModuleType("torch")
    view.__dict__.update(vars(torch))
    view.__getattr__ = lambda name: getattr(torch, name)  # names torch gains later (lazy submodules)
    view.broadcast_shapes = broadcast_shapes
    return view


def import_anny():
    """``import anny`` (see the module docstring); returns the module."""
    if "anny" in sys.modules:
        return sys.modules["anny"]
    import torch

    if os.environ.get("MORF_FULL_TORCH_IMPORT") or "torch._dynamo" in sys.modules or "_dynamo" in vars(torch):
        import anny

        return anny
    torch._dynamo = _stand_in()
    try:
        import anny
    finally:
        if isinstance(vars(torch).get("_dynamo"), types.ModuleType) and "torch._dynamo" not in sys.modules:
            del torch._dynamo
    transforms = sys.modules.get("roma.transforms")
    if transforms is not None and getattr(transforms, "torch", None) is torch:
        transforms.torch = _torch_view(torch)
    return anny
