"""The neural rasterization on the CPU without GL (:mod:`morf.raster.cpu_raster_kernels`).

:class:`CpuNeuralRasterizer` has :class:`~morf.raster.neural_raster.NeuralRasterizer`'s
``draw`` / ``read`` / ``release``, and the player uses it where GL is software (llvmpipe) and numba
imports: ``draw`` skins and projects the mesh and finds each pixel's triangle, ``read`` samples
the texture straight into the caller's buffer. Frames whose vertices leave the depth range
(a camera inside the body) are drawn by GL instead, which clips them.

``read`` writes only the body's bounding box. Each buffer it has filled keeps everything else at
the zero point, so the next frame into the same buffer clears only the last box; a buffer it
has not seen (or one that was freed and replaced) is cleared whole first.
"""

from __future__ import annotations

import weakref

import numpy as np

from morf.raster.neural_raster import FAR, NEAR, NUM_CHANNELS, NeuralRasterizer, SkinnedMesh
from morf.raster.texture_quant import QuantizedTexture


class CpuNeuralRasterizer:
    """Args as :class:`~morf.raster.neural_raster.NeuralRasterizer`'s; ``ctx`` is only used for
    the frames GL has to draw (made on first need)."""

    cpu_skinning = True

    def __init__(self, ctx, mesh: SkinnedMesh, texture: QuantizedTexture, width: int, height: int, num_bones: int):
        from morf.raster import cpu_raster_kernels  # noqa: F401  (numba: fail here, not mid-frame)

        if texture.channels != NUM_CHANNELS:
            raise ValueError(f"the rasterizer expects a {NUM_CHANNELS}-channel texture, got {texture.channels}")
        self.ctx, self.width, self.height, self.num_bones = ctx, int(width), int(height), int(num_bones)
        self._mesh, self._texture_q = mesh, texture
        self._rest = np.ascontiguousarray(mesh.rest_vertices, np.float32)
        self._bone_indices = np.ascontiguousarray(mesh.bone_indices, np.int32)
        self._bone_weights = np.ascontiguousarray(mesh.bone_weights, np.float32)
        self._faces = np.ascontiguousarray(mesh.faces, np.int32)
        self._uvs = np.ascontiguousarray(mesh.uvs, np.float32)
        self._texture = np.ascontiguousarray(texture.data, np.uint8)
        self._posed = np.empty_like(self._rest)
        n = self._rest.shape[0]
        self._sx, self._sy, self._sz, self._iw = (np.empty(n, np.float32) for _ in range(4))
        self._tri = np.full((self.height, self.width), -1, np.int32)
        self._depth = np.full((self.height, self.width), np.inf, np.float32)
        self._box = np.zeros(4, np.int32)  # y0, y1, x0, x1 of the drawn frame (the id buffers hold it)
        self._by_gl = False  # the drawn frame went to GL
        self._gl: NeuralRasterizer | None = None
        self._colour: np.ndarray | None = None  # channels 0-2 set by set_colour (None: the texture's)
        self._buffers: dict[int, tuple[weakref.ref, np.ndarray]] = {}  # id(buffer) -> (buffer, its last box)

    # ---- drawing -----------------------------------------------------------------------------
    def draw(self, bone_transforms: np.ndarray, camera) -> None:
        from morf.raster.cpu_raster_kernels import draw_frame

        if (camera.width, camera.height) != (self.width, self.height):
            raise ValueError(f"camera is {camera.width}x{camera.height}, rasterizer {self.width}x{self.height}")
        T = np.ascontiguousarray(bone_transforms, np.float32)
        if T.shape != (self.num_bones, 4, 4):
            raise ValueError(f"bone transforms must be ({self.num_bones}, 4, 4), got {T.shape}")
        vp = camera.gl_projection(NEAR, FAR).astype(np.float32) @ camera.view_matrix().astype(np.float32)
        self._by_gl = not draw_frame(self._rest, self._bone_indices, self._bone_weights, T, self._posed,
                                     np.ascontiguousarray(vp, np.float32), np.float32(self.width),
                                     np.float32(self.height), self._sx, self._sy, self._sz, self._iw, self._faces,
                                     self._tri, self._depth, self._box)
        if self._by_gl:
            self._gl_rasterizer().draw(T, camera)

    def set_colour(self, rgb: np.ndarray) -> None:
        """Replace the texture's channels 0-2 (bytes (Ht, Wt, 3)) for the frames drawn from now on."""
        if self._texture is self._texture_q.data:
            self._texture = self._texture.copy()  # never write into the loaded avatar's array
        self._texture[..., :3] = rgb
        self._colour = rgb
        if self._gl is not None:
            self._gl.set_colour(rgb)

    def _gl_rasterizer(self) -> NeuralRasterizer:
        if self._gl is None:
            if self.ctx is None:
                from morf.raster.gl_context import create_headless_context

                self.ctx = create_headless_context()
            self._gl = NeuralRasterizer(self.ctx, self._mesh, self._texture_q, self.width, self.height,
                                        self.num_bones, cpu_skinning=True)
            if self._colour is not None:
                self._gl.set_colour(self._colour)
        return self._gl

    # ---- reading -------------------------------------------------------------------------
    def read(self, out: np.ndarray | None = None) -> np.ndarray:
        """The drawn frame as (H, W, 16) uint8 channels last, into ``out`` when given (any
        C-contiguous uint8 array of H*W*16 bytes, e.g. the renderer's (1, H, W, 16) input)."""
        from morf.raster.cpu_raster_kernels import read_frame

        if out is None:
            out = np.empty((self.height, self.width, NUM_CHANNELS), np.uint8)
        if not (out.flags.c_contiguous and out.dtype == np.uint8 and out.size == self.height * self.width * NUM_CHANNELS):
            raise ValueError("read buffer must be C-contiguous uint8 with H*W*16 elements")
        owner = _owner(out)
        whole = np.array([0, self.height, 0, self.width], np.int32)
        if self._by_gl:
            self._gl.read(out)
            box = whole  # GL wrote every pixel
        else:
            known = self._buffers.get(id(owner))
            clear = known[1] if known is not None and known[0]() is owner else whole
            read_frame(self._tri, self._sx, self._sy, self._iw, self._faces, self._uvs, self._texture,
                       out.reshape(self.height, self.width, NUM_CHANNELS), clear, self._box)
            box = self._box.copy()
        if len(self._buffers) > 8:
            self._buffers = {k: v for k, v in self._buffers.items() if v[0]() is not None}
        self._buffers[id(owner)] = (weakref.ref(owner), box)
        return out

    def release(self) -> None:
        if self._gl is not None:
            self._gl.release()
            self._gl = None


def _owner(a: np.ndarray) -> np.ndarray:
    """The array that owns ``a``'s memory (views of one buffer share their record)."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a
