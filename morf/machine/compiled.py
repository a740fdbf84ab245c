"""Whether numba's compiled loops can be used (the player's full-resolution tail, the CPU
skinning under software GL); without numba those fall back to the onnxruntime graph and the
vertex shader."""

from __future__ import annotations

import functools


@functools.cache
def numba_available() -> bool:
    try:
        import numba  # noqa: F401
    except Exception:  # not installed, or a broken install
        return False
    return True
