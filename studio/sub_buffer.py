"""Show a rectangle of the window's back buffer without a buffer swap (GLX_MESA_copy_sub_buffer).

A light frame (:mod:`studio.ui_cache`) changes only the live image. A swap presents the whole
window (on an X server without a GPU, 4 MB a frame at 1280 x 800) and leaves the back buffer
undefined, so the next light frame must first copy the cached UI back. Copying just the image's
rectangle to the front buffer does neither: the back buffer keeps the UI, and a light frame draws
the image and presents it. Where the extension is missing (other drivers, EGL, GLFW's null
platform) :func:`open_sub_buffer` returns None and light frames swap as before.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import glfw


class SubBuffer:
    """``present(x, y, w, h)``: copy that rectangle of the back buffer (GL window coordinates,
    origin bottom left) to the front buffer, with an implicit flush."""

    def __init__(self, copy_sub_buffer, display, drawable):
        self._copy, self._display, self._drawable = copy_sub_buffer, display, drawable

    def present(self, x: int, y: int, width: int, height: int) -> None:
        self._copy(self._display, self._drawable, int(x), int(y), int(width), int(height))


def open_sub_buffer(window) -> SubBuffer | None:
    """The extension for ``window``'s GLX drawable, or None where it is not there."""
    try:
        if glfw.get_platform() != glfw.PLATFORM_X11:
            return None
        display = glfw.get_x11_display()
        drawable = glfw.get_glx_window(window)
        if not display or not drawable:
            return None
        gl = ctypes.CDLL(ctypes.util.find_library("GL") or "libGL.so.1")
        x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
        x11.XDefaultScreen.restype = ctypes.c_int
        x11.XDefaultScreen.argtypes = [ctypes.c_void_p]
        gl.glXQueryExtensionsString.restype = ctypes.c_char_p
        gl.glXQueryExtensionsString.argtypes = [ctypes.c_void_p, ctypes.c_int]
        names = gl.glXQueryExtensionsString(display, x11.XDefaultScreen(display)) or b""
        if b"GLX_MESA_copy_sub_buffer" not in names.split():
            return None
        gl.glXGetProcAddressARB.restype = ctypes.c_void_p
        gl.glXGetProcAddressARB.argtypes = [ctypes.c_char_p]
        address = gl.glXGetProcAddressARB(b"glXCopySubBufferMESA")
        if not address:
            return None
        proto = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                 ctypes.c_int)
        return SubBuffer(proto(address), display, drawable)
    except Exception:  # no GLX, no libGL, a GLFW without native access: swap as before
        return None
