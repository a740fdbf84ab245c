"""Put the live image straight into the X window, without OpenGL (software GL only).

With llvmpipe a light frame's GL work (:mod:`studio.ui_cache`, :mod:`studio.sub_buffer`) is
texturing a 640 x 640 quad on the CPU and copying it out to the X server: about 4.5 ms of a core
for each live frame. The image is already in memory, so the X server can take it as it is:
``XPutImage`` of the pixels, converted to the window's 32-bit BGRX layout (0.35 ms), costs about
0.8 ms of the UI thread. The back buffer keeps the stored UI, as with the sub-buffer copy; the next
full frame draws everything again.

Only where the window's visual is 24-bit TrueColor with the usual red/green/blue masks and the
server takes 32-bit little-endian pixels (Xvfb, Xorg on x86); :func:`open_x_image` returns None
elsewhere (Wayland, other visuals, GLFW's null platform), and on a GPU the GL path is the cheap one.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import glfw
import numpy as np

_LSB_FIRST, _Z_PIXMAP, _TRUE_COLOR = 0, 2, 4


class _Visual(ctypes.Structure):
    _fields_ = [("ext_data", ctypes.c_void_p), ("visualid", ctypes.c_ulong), ("c_class", ctypes.c_int),
                ("red_mask", ctypes.c_ulong), ("green_mask", ctypes.c_ulong), ("blue_mask", ctypes.c_ulong),
                ("bits_per_rgb", ctypes.c_int), ("map_entries", ctypes.c_int)]


class _WindowAttributes(ctypes.Structure):  # XWindowAttributes up to the visual, padded past its end
    _fields_ = [("x", ctypes.c_int), ("y", ctypes.c_int), ("width", ctypes.c_int), ("height", ctypes.c_int),
                ("border_width", ctypes.c_int), ("depth", ctypes.c_int), ("visual", ctypes.POINTER(_Visual)),
                ("rest", ctypes.c_byte * 256)]


class _XImage(ctypes.Structure):  # the leading fields of XImage
    _fields_ = [("width", ctypes.c_int), ("height", ctypes.c_int), ("xoffset", ctypes.c_int),
                ("format", ctypes.c_int), ("data", ctypes.c_void_p), ("byte_order", ctypes.c_int),
                ("bitmap_unit", ctypes.c_int), ("bitmap_bit_order", ctypes.c_int), ("bitmap_pad", ctypes.c_int),
                ("depth", ctypes.c_int), ("bytes_per_line", ctypes.c_int), ("bits_per_pixel", ctypes.c_int)]


def _x11():
    x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    vp, ul, i, u = ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_uint
    x11.XGetWindowAttributes.argtypes = [vp, ul, ctypes.POINTER(_WindowAttributes)]
    x11.XCreateGC.restype, x11.XCreateGC.argtypes = vp, [vp, ul, ul, vp]
    x11.XFreeGC.argtypes = [vp, vp]
    x11.XCreateImage.restype = ctypes.POINTER(_XImage)
    x11.XCreateImage.argtypes = [vp, ctypes.POINTER(_Visual), u, i, i, vp, u, u, i, i]
    x11.XPutImage.argtypes = [vp, ul, vp, ctypes.POINTER(_XImage), i, i, i, i, u, u]
    x11.XFlush.argtypes = [vp]
    x11.XFree.argtypes = [vp]
    return x11


class XImagePresenter:
    """:meth:`present` an (n, n, 3) uint8 RGB image at a window position; :meth:`close` when done.
    Owned by the UI thread (GLFW's X connection is used from it alone)."""

    def __init__(self, x11, display, window, visual):
        self._x11, self._display, self._window, self._visual = x11, display, window, visual
        self._gc = x11.XCreateGC(display, window, 0, None)
        self._buffer: np.ndarray | None = None
        self._image = None

    def _image_for(self, n: int):
        if self._buffer is None or self._buffer.shape[0] != n:
            self._free_image()
            self._buffer = np.zeros((n, n, 4), np.uint8)
            image = self._x11.XCreateImage(self._display, self._visual, 24, _Z_PIXMAP, 0,
                                           self._buffer.ctypes.data, n, n, 32, 0)
            if not image:
                raise OSError("XCreateImage failed")
            im = image.contents
            if im.bits_per_pixel != 32 or im.byte_order != _LSB_FIRST or im.bytes_per_line != 4 * n:
                im.data = None
                self._x11.XFree(image)
                raise OSError(f"the X server wants {im.bits_per_pixel}-bit pixels in byte order {im.byte_order}")
            self._image = image
        return self._image

    def present(self, rgb: np.ndarray, x: int, y: int) -> None:
        """Put ``rgb`` with its top left corner at window pixel (x, y)."""
        n = rgb.shape[0]
        image = self._image_for(n)
        buf = self._buffer
        buf[..., 0], buf[..., 1], buf[..., 2] = rgb[..., 2], rgb[..., 1], rgb[..., 0]  # BGRX
        self._x11.XPutImage(self._display, self._window, self._gc, image, 0, 0, int(x), int(y), n, n)
        self._x11.XFlush(self._display)  # Xlib copied the pixels into its request: the buffer is free

    def _free_image(self) -> None:
        if self._image is not None:
            self._image.contents.data = None  # the pixels are numpy's: free the XImage struct only
            self._x11.XFree(self._image)
            self._image = None

    def close(self) -> None:
        self._free_image()
        if self._gc:
            self._x11.XFreeGC(self._display, self._gc)
            self._gc = None


def open_x_image(window) -> XImagePresenter | None:
    """The presenter for ``window``, or None where the X server cannot take the image this way."""
    try:
        if glfw.get_platform() != glfw.PLATFORM_X11:
            return None
        display, xwindow = glfw.get_x11_display(), glfw.get_x11_window(window)
        if not display or not xwindow:
            return None
        x11 = _x11()
        attrs = _WindowAttributes()
        if not x11.XGetWindowAttributes(display, xwindow, ctypes.byref(attrs)) or not attrs.visual:
            return None
        v = attrs.visual.contents
        if (attrs.depth != 24 or v.c_class != _TRUE_COLOR
                or (v.red_mask, v.green_mask, v.blue_mask) != (0xFF0000, 0x00FF00, 0x0000FF)):
            return None
        presenter = XImagePresenter(x11, display, xwindow, attrs.visual)
        presenter._image_for(16)  # the server's pixel layout is checked here, once
        return presenter
    except Exception:  # no libX11, a GLFW without native access, another pixel layout
        return None
