"""``glFinish`` that lets other Python threads run while the GL driver works.

moderngl's ``ctx.finish()`` holds Python's GIL until the driver is done. With software GL
(llvmpipe) the driver rasterizes on its own threads, so that wait is idle time in which no other
Python thread of the process may run: the studio's UI thread waits on the live render's
rasterization, and the live render's renderer thread on the UI's drawing. A call through ctypes
releases the GIL for its duration. :func:`gil_free_finish` looks ``glFinish`` up for the context
current on the calling thread (EGL: ``eglGetProcAddress``; GLX: ``glXGetProcAddressARB``) and
falls back to ``ctx.finish`` where neither finds it.
"""

from __future__ import annotations

import ctypes
import ctypes.util
from typing import Callable

_FINISH = ctypes.CFUNCTYPE(None)


def _lookup(library: str, fallback: str, current_context: str, get_proc_address: str) -> int | None:
    """glFinish's address from ``library`` when it has a context current on this thread."""
    try:
        lib = ctypes.CDLL(ctypes.util.find_library(library) or fallback)
        current, get_proc = getattr(lib, current_context), getattr(lib, get_proc_address)
    except (OSError, AttributeError):  # no such library, or one without this API (a libGL without GLX)
        return None
    current.restype, get_proc.restype, get_proc.argtypes = ctypes.c_void_p, ctypes.c_void_p, [ctypes.c_char_p]
    if not current():
        return None
    return get_proc(b"glFinish") or None


LOOKUPS = (("EGL", "libEGL.so.1", "eglGetCurrentContext", "eglGetProcAddress"),
           ("GL", "libGL.so.1", "glXGetCurrentContext", "glXGetProcAddressARB"))


def gil_free_finish(ctx) -> Callable[[], None]:
    """A ``glFinish`` for ``ctx``, which must be current on the calling thread now and whenever
    the returned function is called; ``ctx.finish`` where no GL library offers the function."""
    for names in LOOKUPS:
        try:
            address = _lookup(*names)
        except Exception:  # an unusual GL stack: keep moderngl's own call
            address = None
        if address:
            return _FINISH(address)
    return ctx.finish
