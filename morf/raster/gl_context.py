"""The headless OpenGL contexts (moderngl on EGL): one per thread, created on first use.

An OpenGL context is current on one thread only, and moderngl objects (buffers, programs,
textures) belong to the context that made them. So every thread that rasterizes gets its own
standalone EGL context, and the GL objects cached for it (programs, framebuffers, meshes)
live beside it in a :class:`GLState`. Mesa's llvmpipe gives OpenGL 4.5 without a GPU.

Every public rasterizer runs inside :func:`current`: our context is made current for the call
and whatever context was current before (an app window, another library's) is current again
afterwards. On a thread that owns a window, :func:`adopt_gl_context` shares the window's
context instead of creating a second one.

Every standalone context of the library comes from :func:`create_headless_context`, under one
lock: the per-thread ones here, and those the player and the export own themselves.
"""

from __future__ import annotations

import contextlib
import functools
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


SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "swiftshader")


def software_gl(ctx) -> bool:
    """Whether ``ctx`` rasterizes on the CPU (Mesa's llvmpipe and kin), from its ``GL_RENDERER``;
    True for a context that cannot say (the common case without a GPU)."""
    try:
        renderer = str(ctx.info.get("GL_RENDERER", "")).lower()
    except Exception:
        return True
    return any(name in renderer for name in SOFTWARE_GL)


def _release(obj) -> None:
    if obj is None:
        return
    rel = getattr(obj, "release", None)
    if callable(rel):
        rel()


def create_headless_context():
    """A new standalone moderngl context on EGL (Mesa llvmpipe without a GPU); the caller owns it.

    It becomes current on the calling thread. Raises :class:`GLUnavailable` with a one-line hint
    when EGL cannot give a context.
    """
    import moderngl

    with _CREATE_LOCK:
        try:
            return moderngl.create_standalone_context(backend="egl")
        except Exception as e:  # moderngl raises plain Exception for EGL failures
            raise GLUnavailable(f"cannot create a headless OpenGL context through EGL ({e}); "
                                "install the system packages libegl1 and libgl1") from None


# Why EGL gave no context, once it failed: a missing driver does not appear later in the process,
# and callers with a torch fallback (the fit's silhouettes, every step) should not retry each time.
_EGL_FAILURE: list[str] = []


def gl_state() -> GLState:
    """The calling thread's :class:`GLState` (context made on first call).

    Raises :class:`GLUnavailable` with a one-line hint when EGL cannot give a context (after the
    first failure at once, without trying again).
    """
    state = getattr(_LOCAL, "state", None)
    if state is None:
        if _EGL_FAILURE:
            raise GLUnavailable(_EGL_FAILURE[0])
        try:
            ctx = create_headless_context()
        except GLUnavailable as e:
            _EGL_FAILURE.append(str(e))
            raise
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


def with_gl_context(fn):
    """Run ``fn`` with this thread's context made current, restoring the previous one after.

    Other code on the same thread may make its own context current (a window, another
    standalone context); entering ours around every call keeps both working.
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with current(gl_state()):
            return fn(*args, **kwargs)

    return wrapper


@contextlib.contextmanager
def current(state: GLState):
    """Make ``state``'s context current inside the block; the previous one is current after."""
    previous = _egl_current()
    try:
        with state.ctx:
            yield state
    finally:
        _egl_restore(previous)


_EGL = None


def _egl():
    """libEGL through ctypes, or False where it cannot be loaded."""
    global _EGL
    if _EGL is None:
        import ctypes

        try:
            lib = ctypes.CDLL("libEGL.so.1")
            for name in ("eglGetCurrentContext", "eglGetCurrentDisplay", "eglGetCurrentSurface"):
                getattr(lib, name).restype = ctypes.c_void_p
            lib.eglGetCurrentSurface.argtypes = [ctypes.c_int]
            lib.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
            lib.eglMakeCurrent.restype = ctypes.c_uint
            _EGL = lib
        except (OSError, AttributeError):
            _EGL = False
    return _EGL


def _egl_current():
    """(display, draw, read, context) current on this thread, or None."""
    lib = _egl()
    if not lib:
        return None
    ctx = lib.eglGetCurrentContext()
    if not ctx:
        return None
    return lib.eglGetCurrentDisplay(), lib.eglGetCurrentSurface(0x3059), lib.eglGetCurrentSurface(0x305A), ctx


def _egl_restore(previous) -> None:
    # moderngl's context exit on EGL does not give the previous context back; do it here so a
    # window or another library's context stays current across our calls.
    if previous is not None:
        _egl().eglMakeCurrent(*previous)


def gl_context():
    """The calling thread's moderngl context."""
    return gl_state().ctx


def release_gl_context() -> None:
    """Release the calling thread's context and everything cached for it (e.g. at thread end)."""
    state = getattr(_LOCAL, "state", None)
    if state is not None:
        _LOCAL.state = None
        previous = _egl_current()
        with state.ctx:
            state.owned, owned = False, state.owned
            state.release()  # cached objects only: the context is released after leaving it
        if owned:
            state.ctx.release()
        _egl_restore(previous)
