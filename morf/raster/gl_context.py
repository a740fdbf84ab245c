"""The headless OpenGL context (moderngl on EGL): one per thread, created on first use.

An OpenGL context is current on one thread only, and moderngl objects (buffers, programs,
textures) belong to the context that made them. So every thread that rasterizes gets its own
standalone EGL context, and the GL objects cached for it (programs, framebuffers, meshes)
live beside it in a :class:`GLState`. Mesa's llvmpipe gives OpenGL 4.5 without a GPU.
"""

from __future__ import annotations

import threading
from typing import Any, Callable

from morf.errors import MorfError

_LOCAL = threading.local()
# EGL display initialisation in Mesa is not guaranteed to be re-entrant: create one at a time.
_CREATE_LOCK = threading.Lock()


class GLUnavailable(MorfError):
    """No OpenGL context could be created (missing EGL / GL libraries)."""


class GLState:
    """A thread's context plus the GL objects cached for it.

    ``cached(key, make)`` returns the object stored under ``key``, building it with ``make()``
    the first time; programs, framebuffers and vertex buffers are reused across frames this way.
    """

    def __init__(self, ctx, owned: bool = True):
        self.ctx = ctx
        self.owned = owned  # False for an adopted context: its owner releases it
        self._cache: dict[Any, Any] = {}

    def cached(self, key, make: Callable[[], Any]):
        obj = self._cache.get(key)
        if obj is None:
            obj = make()
            self._cache[key] = obj
        return obj

    def drop(self, key) -> None:
        """Forget (and release) one cached object."""
        obj = self._cache.pop(key, None)
        _release(obj)

    def keys(self) -> list:
        return list(self._cache)

    def release(self) -> None:
        for obj in self._cache.values():
            _release(obj)
        self._cache.clear()
        if self.owned:
            self.ctx.release()


def _release(obj) -> None:
    if obj is None:
        return
    rel = getattr(obj, "release", None)
    if callable(rel):
        rel()


def gl_state() -> GLState:
    """The calling thread's :class:`GLState` (context made on first call).

    Raises :class:`GLUnavailable` with a one-line hint when EGL cannot give a context.
    """
    state = getattr(_LOCAL, "state", None)
    if state is None:
        import moderngl

        with _CREATE_LOCK:
            try:
                ctx = moderngl.create_standalone_context(backend="egl")
            except Exception as e:  # moderngl raises plain Exception for EGL failures
                raise GLUnavailable(
                    f"cannot create a headless OpenGL context through EGL ({e}); "
                    "install the system packages libegl1 and libgl1") from None
        state = GLState(ctx)
        _LOCAL.state = state
    return state


def adopt_gl_context(ctx) -> GLState:
    """Use an existing moderngl context (e.g. an app window's) for this thread's rasterization.

    Needed on a thread that already has a window context current: creating a standalone one
    there would make it current instead. The rasterizers bind their own framebuffers and set
    the viewport, depth test and blending; the caller re-binds its screen afterwards.
    """
    old = getattr(_LOCAL, "state", None)
    if old is not None and old.ctx is not ctx:
        old.release()
    state = GLState(ctx, owned=False) if old is None or old.ctx is not ctx else old
    _LOCAL.state = state
    return state


def gl_context():
    """The calling thread's moderngl context."""
    return gl_state().ctx


def release_gl_context() -> None:
    """Release the calling thread's context and everything cached for it (e.g. at thread end)."""
    state = getattr(_LOCAL, "state", None)
    if state is not None:
        _LOCAL.state = None
        state.release()
