"""Put the live image straight into the X window, without OpenGL (software GL only).

With llvmpipe a light frame's GL work (:mod:`studio.ui_cache`, :mod:`studio.sub_buffer`) is
texturing a 640 x 640 quad on the CPU and copying it out to the X server: about 4.5 ms of a core
for each live frame. The image is already in memory, so the X server can take it as it is:
``XPutImage`` of the pixels, converted to the window's 32-bit BGRX layout (0.35 ms), costs about
0.8 ms of the UI thread. The back buffer keeps the stored UI, as with the sub-buffer copy; the next
full frame draws everything again.

On a local X server with the MIT-SHM extension the pixels go through shared memory instead
(``XShmPutImage``, :class:`ShmXImagePresenter`): the conversion writes them where the server reads
them, and nothing crosses the socket (``MORF_XSHM=0`` keeps the plain path).

Only where the window's visual is 24-bit TrueColor with the usual red/green/blue masks and the
server takes 32-bit little-endian pixels (Xvfb, Xorg on x86); :func:`open_x_image` returns None
elsewhere (Wayland, other visuals, GLFW's null platform), and on a GPU the GL path is the cheap one.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os

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


class _ShmSegmentInfo(ctypes.Structure):  # XShmSegmentInfo
    _fields_ = [("shmseg", ctypes.c_ulong), ("shmid", ctypes.c_int), ("shmaddr", ctypes.c_void_p),
                ("readOnly", ctypes.c_int)]


_ERROR_HANDLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p)
_IPC_PRIVATE, _IPC_CREAT, _IPC_RMID = 0, 0o1000, 0


def _xext():
    xext = ctypes.CDLL(ctypes.util.find_library("Xext") or "libXext.so.6")
    vp, ul, i, u = ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_uint
    xext.XShmQueryExtension.argtypes = [vp]
    xext.XShmCreateImage.restype = ctypes.POINTER(_XImage)
    xext.XShmCreateImage.argtypes = [vp, ctypes.POINTER(_Visual), u, i, vp, ctypes.POINTER(_ShmSegmentInfo), u, u]
    xext.XShmAttach.argtypes = xext.XShmDetach.argtypes = [vp, ctypes.POINTER(_ShmSegmentInfo)]
    xext.XShmPutImage.argtypes = [vp, ul, vp, ctypes.POINTER(_XImage), i, i, i, i, u, u, i]
    return xext


def _libc():
    libc = ctypes.CDLL(None, use_errno=True)
    libc.shmget.argtypes = [ctypes.c_int, ctypes.c_size_t, ctypes.c_int]
    libc.shmat.restype, libc.shmat.argtypes = ctypes.c_void_p, [ctypes.c_int, ctypes.c_void_p, ctypes.c_int]
    libc.shmdt.argtypes = [ctypes.c_void_p]
    libc.shmctl.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_void_p]
    return libc


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
    x11.XSync.argtypes = [vp, i]
    x11.XFree.argtypes = [vp]
    x11.XSetErrorHandler.restype, x11.XSetErrorHandler.argtypes = vp, [vp]
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


class ShmXImagePresenter(XImagePresenter):
    """The same through MIT-SHM: the image's pixels live in a shared memory segment the X server
    has attached, so :meth:`present` converts straight into it and sends a request of a few bytes."""

    def __init__(self, x11, display, window, visual):
        super().__init__(x11, display, window, visual)
        self._xext, self._libc = _xext(), _libc()
        self._info: _ShmSegmentInfo | None = None

    def _image_for(self, n: int):
        if self._buffer is not None and self._buffer.shape[0] == n:
            return self._image
        self._free_image()
        info = _ShmSegmentInfo()
        image = self._xext.XShmCreateImage(self._display, self._visual, 24, _Z_PIXMAP, None, ctypes.byref(info), n, n)
        if not image:
            raise OSError("XShmCreateImage failed")
        im = image.contents
        if im.bits_per_pixel != 32 or im.byte_order != _LSB_FIRST or im.bytes_per_line != 4 * n:
            self._x11.XFree(image)
            raise OSError(f"the X server wants {im.bits_per_pixel}-bit pixels in byte order {im.byte_order}")
        info.shmid = self._libc.shmget(_IPC_PRIVATE, 4 * n * n, _IPC_CREAT | 0o600)
        if info.shmid < 0:
            self._x11.XFree(image)
            raise OSError(ctypes.get_errno(), "shmget failed")
        addr = self._libc.shmat(info.shmid, None, 0)
        self._libc.shmctl(info.shmid, _IPC_RMID, None)  # gone once both sides detach, even after a crash
        if addr in (None, ctypes.c_void_p(-1).value):
            self._x11.XFree(image)
            raise OSError(ctypes.get_errno(), "shmat failed")
        info.shmaddr = im.data = addr
        info.readOnly = 1
        if not self._attach(info):
            self._libc.shmdt(addr)
            im.data = None
            self._x11.XFree(image)
            raise OSError("the X server could not attach the shared memory (a remote display?)")
        self._info, self._image = info, image
        self._buffer = np.ctypeslib.as_array(ctypes.cast(addr, ctypes.POINTER(ctypes.c_uint8)), (n, n, 4))
        self._buffer[...] = 0
        return image

    def _attach(self, info: _ShmSegmentInfo) -> bool:
        """XShmAttach with the X errors caught (Xlib's default handler would end the process)."""
        failed = []
        handler = _ERROR_HANDLER(lambda display, event: failed.append(1) or 0)
        previous = self._x11.XSetErrorHandler(ctypes.cast(handler, ctypes.c_void_p))
        try:
            ok = self._xext.XShmAttach(self._display, ctypes.byref(info))
            self._x11.XSync(self._display, 0)
        finally:
            self._x11.XSetErrorHandler(previous)
        return bool(ok) and not failed

    def present(self, rgb: np.ndarray, x: int, y: int) -> None:
        n = rgb.shape[0]
        image = self._image_for(n)
        buf = self._buffer
        buf[..., 0], buf[..., 1], buf[..., 2] = rgb[..., 2], rgb[..., 1], rgb[..., 0]  # BGRX
        self._xext.XShmPutImage(self._display, self._window, self._gc, image, 0, 0, int(x), int(y), n, n, 0)
        self._x11.XSync(self._display, 0)  # the server has read the segment: the next frame may write it

    def _free_image(self) -> None:
        if self._image is None:
            return
        self._xext.XShmDetach(self._display, ctypes.byref(self._info))
        self._x11.XSync(self._display, 0)
        self._libc.shmdt(ctypes.c_void_p(self._info.shmaddr))
        self._image.contents.data = None
        self._x11.XFree(self._image)
        self._image, self._info, self._buffer = None, None, None


def _local_display() -> bool:
    name = os.environ.get("DISPLAY", "")
    return name.startswith(":") or name.startswith("unix:")


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
        if os.environ.get("MORF_XSHM", "1") != "0" and _local_display():
            try:
                if _xext().XShmQueryExtension(display):
                    shm = ShmXImagePresenter(x11, display, xwindow, attrs.visual)
                    try:
                        shm._image_for(16)  # the layout and the attach are checked here, once
                        return shm
                    except OSError:
                        shm.close()
            except OSError:
                pass  # no libXext or no shared memory: the plain requests below
        presenter = XImagePresenter(x11, display, xwindow, attrs.visual)
        presenter._image_for(16)  # the server's pixel layout is checked here, once
        return presenter
    except Exception:  # no libX11, a GLFW without native access, another pixel layout
        return None
