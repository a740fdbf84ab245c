"""Real-time playback of an exported avatar: pose in, composited image out (torch-free).

Per frame: numpy forward kinematics (bone matrices) -> neural rasterization straight into the
renderer's channels-last input (16 uint8 channels): numba loops on the CPU where GL is software
(:mod:`morf.raster.cpu_raster`), else GL (skinning in the vertex shader, the channels packed into
one RGBA32UI attachment, read back) -> int8 renderer + composite over the background, both in one
onnxruntime graph. :meth:`Player.render_sequence` overlaps the GL work of frame t+1 with the
renderer on frame t (onnxruntime releases the GIL).
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np

from morf.errors import InputError
from morf.export.avatar_folder import ExportedAvatar, load_exported_avatar
from morf.playback.onnx_renderer import OnnxRenderer, background_planes
from morf.raster.gl_context import create_headless_context
from morf.raster.gl_finish import gil_free_finish
from morf.raster.neural_raster import NUM_CHANNELS, NeuralRasterizer, to_layout


@dataclass(frozen=True)
class PreparedFrame:
    """One frame between the player's two stages (:meth:`Player.prepare` -> :meth:`Player.complete`).

    Fields:
        raster: the renderer input (uint8, in the avatar's layout); it lives in the buffer it was
            prepared into, so it is valid until that buffer is prepared into again.
        box: the part of the image a close-up enlarges (``morf.raster.view_scale``), or None.
    """

    raster: np.ndarray
    box: tuple[float, float, float, float] | None


class Player:
    """Plays an exported avatar.

    Args:
        avatar_dir: a folder written by ``morf export``, checked on load with its sha256 sums
            (:func:`~morf.export.avatar_folder.load_exported_avatar`), or an :class:`ExportedAvatar`
            (one loaded with ``verify=False`` skips the sums, for a caller that has just checked them).
        size: output side in pixels (square; a multiple of the renderer's size multiple).
        ctx: a moderngl context to draw in (e.g. the studio window's); None makes a headless one.
        precision: "int8" (default) or "fp32" renderer.
        background: RGB colour triple or (size, size, 3) uint8 image.
        threads: onnxruntime intra-op threads; spinning: let idle ORT threads spin (benchmarks only).
        native: run the graph's full-resolution tail as one compiled pass where the avatar folder
            has one (:mod:`morf.playback.native_tail`; ``MORF_NATIVE_TAIL=0`` turns it off too).
        raster: "gl", "cpu" (:mod:`morf.raster.cpu_raster`, numba) or "auto": the CPU loops where
            GL is software (llvmpipe) and numba imports, GL on a GPU. ``MORF_RASTER`` overrides "auto".
    """

    def __init__(self, avatar_dir, size: int = 640, ctx=None, precision: str = "int8",
                 background=(255, 255, 255), threads: int = 2, spinning: bool = False, native: bool = True,
                 raster: str = "auto"):
        self.avatar = avatar_dir if isinstance(avatar_dir, ExportedAvatar) else load_exported_avatar(avatar_dir)
        mult = self.avatar.size_multiple
        if size <= 0 or size % mult:
            raise InputError(f"player size must be a positive multiple of {mult}, got {size}")
        self.size = int(size)
        self._own_ctx = ctx is None
        self.ctx = ctx or create_headless_context()
        self.raster_kind = choose_raster(raster, self.ctx)
        args = (self.ctx, self.avatar.mesh, self.avatar.texture, size, size, self.avatar.skeleton.num_bones)
        if self.raster_kind == "cpu":
            from morf.raster.cpu_raster import CpuNeuralRasterizer

            self.raster = CpuNeuralRasterizer(*args)
            self._gl_finish = _no_gl_work  # its frames that GL draws are read back, which waits for them
        else:
            self.raster = NeuralRasterizer(*args)
            self._gl_finish = gil_free_finish(self.ctx)  # other threads run while llvmpipe rasterizes
        self.precision = precision
        self.renderer = open_renderer(self.avatar, precision, threads=threads, spinning=spinning, native=native,
                                      size=self.size)
        self.background = background
        # the largest scale the renderer was trained at; closer views are drawn through it (None: no limit)
        self.max_pixels_per_metre = (self.avatar.manifest.get("trained_scale") or {}).get("max_pixels_per_metre")
        self._hwc = np.empty((size, size, NUM_CHANNELS), np.uint8)
        self._input = self.new_input()
        self.output_texture = None
        self.last_timings: dict[str, float] = {}
        self._view_key = None  # the view colours' blend last set in the rasterizer

    @property
    def background(self):
        return self._background_value

    @background.setter
    def background(self, value) -> None:
        """RGB colour triple or (size, size, 3) image, 0-255."""
        try:
            self._background = background_planes(value, self.size)
        except ValueError as e:
            raise InputError(str(e)) from None
        self._background_value = value
        self._flat_background = np.ndim(value) == 1  # a colour: enlarging a close-up leaves it as it is

    @property
    def background_planes(self) -> np.ndarray:
        """The background as the renderer graph's ``background`` input."""
        return self._background

    # ---- the stages ------------------------------------------------------------------------
    def _camera(self, camera):
        if (camera.width, camera.height) == (self.size, self.size):
            return camera
        if camera.width != camera.height:
            raise InputError(f"camera is {camera.width}x{camera.height}; the player renders square {self.size}px images")
        return camera.scaled(self.size / camera.width)

    def _view_colour(self, pose_rotvecs: np.ndarray, camera, bones: np.ndarray) -> None:
        """Set the rasterizer's colour channels to the view colours' blend for this pose's root
        orientation relative to ``camera`` (:mod:`morf.avatar.view_colour`), with the head's own
        colours laid over by the head bone's (its skinning rotation in ``bones``, the pose's (J, 4, 4)
        bone transforms; :mod:`morf.avatar.head_colour`); a blend already set is kept."""
        from morf.avatar.head_colour import head_orientation
        from morf.avatar.view_colour import view_orientation

        views = self.avatar.view_colours
        R = getattr(camera, "R", None)
        R = np.eye(3) if R is None else R
        orientation = view_orientation(R, self.avatar.skeleton.reference_rotations[0],
                                       np.asarray(pose_rotvecs, np.float64)[0])
        key = views.blend_weights(orientation)
        head = views.head
        head_key = None if head is None else head.blend_weights(head_orientation(R, bones[head.bone, :3, :3]))
        if (key, head_key) != self._view_key:
            rgb = views.blend(orientation, key)
            self.raster.set_colour(rgb if head is None else head.lay_over(rgb, head_key))
            self._view_key = (key, head_key)

    def rasterize(self, pose_rotvecs: np.ndarray, transl: np.ndarray, camera, out: np.ndarray | None = None) -> np.ndarray:
        """The renderer input for one pose, in the renderer's layout (uint8)."""
        t0 = time.perf_counter()
        T = self.avatar.skeleton.bone_transforms(pose_rotvecs, transl)
        if self.avatar.view_colours is not None:
            self._view_colour(pose_rotvecs, camera, T)
        t1 = time.perf_counter()
        self.raster.draw(T, self._camera(camera))
        self._gl_finish()
        t2 = time.perf_counter()
        layout = self.avatar.input_layout
        if layout == "nhwc":  # the read-back is the renderer input: read into the caller's buffer
            x = self.raster.read(self._input if out is None else out)
            t3 = t4 = time.perf_counter()
        else:
            hwc = self.raster.read(self._hwc)
            t3 = time.perf_counter()
            x = to_layout(hwc, layout, self._input if out is None else out)
            t4 = time.perf_counter()
        self.last_timings.update(bones_ms=(t1 - t0) * 1e3, raster_ms=(t2 - t1) * 1e3, readback_ms=(t3 - t2) * 1e3,
                                 layout_ms=(t4 - t3) * 1e3)
        return x

    def shade(self, raster: np.ndarray) -> np.ndarray:
        """Renderer + composite: uint8 raster -> (H, W, 3) uint8."""
        t0 = time.perf_counter()
        img = self.renderer.image(raster, self._background)
        t1 = time.perf_counter()
        self.last_timings.update(renderer_ms=(t1 - t0) * 1e3)  # the composite runs inside the renderer's graph
        self.last_timings.update(getattr(self.renderer, "last_timings", {}))  # the native tail's split
        return img

    def view(self, transl: np.ndarray, camera) -> tuple[object, tuple[float, float, float, float] | None]:
        """(the camera to draw, the box of its image to enlarge or None) for a body at ``transl``.

        A camera closer than the scale the renderer was trained at (the avatar folder's
        ``trained_scale``) is drawn as a wider view at that scale, and the part it shows enlarged
        (:mod:`morf.raster.view_scale`): the renderer's mask breaks into holes at scales it never
        saw. Only over a flat background colour (an image background would be enlarged too)."""
        from morf.raster.view_scale import close_up

        camera = self._camera(camera)
        near = close_up(camera, transl, self.max_pixels_per_metre) if self._flat_background else None
        return (camera, None) if near is None else (near.camera, near.box)

    def _finish(self, image: np.ndarray, box) -> np.ndarray:
        if box is None:
            return image
        from morf.raster.view_scale import enlarge

        t0 = time.perf_counter()
        out = enlarge(image, box)
        self.last_timings.update(enlarge_ms=(time.perf_counter() - t0) * 1e3)
        return out

    # ---- public entry points -----------------------------------------------------------------
    def prepare(self, pose_rotvecs: np.ndarray, transl: np.ndarray, camera,
                out: np.ndarray | None = None) -> PreparedFrame:
        """The first stage of a frame, the GL work: the renderer input for one pose (into ``out``,
        a buffer from :meth:`new_input`, when given; else the player's own, reused per call)."""
        camera, box = self.view(transl, camera)
        return PreparedFrame(self.rasterize(pose_rotvecs, transl, camera, out=out), box)

    def complete(self, frame: PreparedFrame) -> np.ndarray:
        """The second stage, no GL: renderer + composite (+ the close-up's enlargement) ->
        (size, size, 3) uint8. It may run on another thread than :meth:`prepare` (onnxruntime
        releases the GIL), as long as ``frame``'s buffer is not prepared into meanwhile."""
        return self._finish(self.shade(frame.raster), frame.box)

    def new_input(self) -> np.ndarray:
        """A buffer for one renderer input in the avatar's layout (``to_layout`` knows the shapes),
        e.g. :meth:`prepare`'s ``out`` (two let one frame be prepared while the last completes)."""
        return np.empty_like(to_layout(self._hwc, self.avatar.input_layout))

    def render(self, pose_rotvecs: np.ndarray, transl: np.ndarray, camera, on_rasterized=None) -> np.ndarray:
        """One frame: (J, 3) axis-angle pose, (3,) translation, a PinholeCamera -> (size, size, 3) uint8.

        ``on_rasterized``: called between the GL rasterization and the renderer, e.g. to tell an
        app's UI thread that this thread's GL work (which holds Python's GIL) is done."""
        frame = self.prepare(pose_rotvecs, transl, camera)
        if on_rasterized is not None:
            on_rasterized()
        return self.complete(frame)

    def render_texture(self, pose_rotvecs: np.ndarray, transl: np.ndarray, camera):
        """Like :meth:`render` but leaves the image in a moderngl RGB8 texture (for the studio).

        The texture is reused between calls; row 0 of the texture is the image's top row.
        """
        img = self.render(pose_rotvecs, transl, camera)
        if self.output_texture is None:
            self.output_texture = self.ctx.texture((self.size, self.size), 3)
            self.output_texture.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        self.output_texture.write(np.ascontiguousarray(img).tobytes())
        return self.output_texture

    def render_sequence(self, frames: Iterable[tuple[np.ndarray, np.ndarray, object]],
                        pipelined: bool = True) -> Iterator[np.ndarray]:
        """Render (rotvecs, transl, camera) frames in order; yields (size, size, 3) uint8 images.

        With ``pipelined`` the renderer runs frame t in a worker thread while this thread
        rasterizes frame t+1 (GL stays on the thread whose context is current).
        """
        if not pipelined:
            for rot, tr, cam in frames:
                yield self.render(rot, tr, cam)
            return
        buffers = [self.new_input() for _ in range(2)]
        with ThreadPoolExecutor(max_workers=1) as pool:
            pending = None
            for i, (rot, tr, cam) in enumerate(frames):
                frame = self.prepare(rot, tr, cam, out=buffers[i % 2])
                if pending is not None:
                    yield pending.result()
                pending = pool.submit(self.complete, frame)
            if pending is not None:
                yield pending.result()

    def release(self) -> None:
        self.raster.release()
        if self.output_texture is not None:
            self.output_texture.release()
        if self._own_ctx:
            self.ctx.release()

    def __enter__(self) -> "Player":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


RASTERS = ("auto", "gl", "cpu")


def choose_raster(kind: str, ctx) -> str:
    """"gl" or "cpu" for a player's ``raster`` argument (see :class:`Player`)."""
    import os

    from morf.machine.compiled import numba_available
    from morf.raster.gl_context import software_gl

    if kind == "auto":
        kind = os.environ.get("MORF_RASTER", "auto").strip().lower() or "auto"
    if kind not in RASTERS:
        raise InputError(f"raster must be one of {', '.join(RASTERS)}, got {kind!r}")
    if kind == "cpu" and not numba_available():
        raise InputError("the CPU rasterizer needs numba, which does not import here")
    if kind == "auto":
        kind = "cpu" if numba_available() and software_gl(ctx) else "gl"
    return kind


def _no_gl_work() -> None:
    pass


def open_renderer(avatar: ExportedAvatar, precision: str, threads: int = 2, spinning: bool = False,
                  native: bool = True, size: int | None = None):
    """The avatar's renderer: its graph cut before the full-resolution tail + the compiled tail
    where the folder has one and it may be used, else the whole graph."""
    from morf.playback.native_tail import TailRenderer, enabled, spec_for

    spec = spec_for(avatar.manifest, precision) if native else None
    if spec is not None and enabled():
        return TailRenderer(avatar.renderer_path(precision), spec, threads=threads, spinning=spinning, size=size)
    return OnnxRenderer(avatar.renderer_path(precision), threads=threads, spinning=spinning, size=size)


def load_avatar(avatar_dir: str | Path) -> ExportedAvatar:
    """The avatar folder, checked (:func:`load_exported_avatar`), with a one-line error for a missing one."""
    if not Path(avatar_dir).is_dir():
        raise InputError(f"avatar folder not found: {avatar_dir}")
    return load_exported_avatar(avatar_dir)


def open_player(avatar: str | Path | ExportedAvatar, **kwargs) -> Player:
    """:class:`Player` of an avatar folder (or one already loaded), with one-line errors for a missing folder."""
    return Player(avatar if isinstance(avatar, ExportedAvatar) else load_avatar(avatar), **kwargs)
