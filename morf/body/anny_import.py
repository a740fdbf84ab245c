"""Import Anny without paying for torch's compiler.

Anny imports ``roma``, and ``roma.mappings`` wraps two autograd Functions in
``torch._dynamo.disable(...)`` at import time. That attribute access makes torch import its whole
compiler stack (``torch._dynamo``, sympy, the FX symbolic shapes), 1.3-1.4 s on two CPU cores,
paid by every command that loads the body model. MoRF Studio never runs ``torch.compile``, and
``disable`` only changes how those two Functions behave inside a compiled graph.

So while Anny is imported, and only if torch's compiler is not loaded yet, ``torch._dynamo``
resolves to a small stand-in whose ``disable`` returns the function unchanged. The stand-in is
removed right after, so any later ``torch._dynamo`` access imports the real module as usual.
``MORF_FULL_TORCH_IMPORT=1`` turns this off.
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
    return anny
