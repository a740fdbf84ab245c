"""Live neural rasterization in OpenGL: GPU skinning + 16-channel uint8 texture lookup.

What the paper's phone app does per frame: skin the render mesh in the vertex shader from the
frame's bone matrices, sample the quantised neural texture (four RGBA8 textures, bilinear) and
write the 16 channels, still 8-bit, packed into one RGBA32UI colour attachment (16 bytes a pixel)
cleared to 128 (= 0). Reading it back gives the int8 renderer's channels-last input (H, W, 16)
without any float conversion or re-layout. The bytes also carry the coverage: on the body
channel :data:`COVERAGE_CHANNEL`'s byte is never 128 (the shader writes 129 for it, one step of
one channel), so the renderer graph finds the body from that one byte plane instead of all 16
(:func:`morf.export.onnx_graph.uint8_colour_head`; :func:`mark_coverage` for rasters made
elsewhere). (Four RGBA8 attachments were the first design: they
need an interleaving copy on the CPU, and drawing into them was slower on Mesa llvmpipe.)

Torch-free on purpose (numpy + moderngl): an exported avatar plays without torch. Export draws
its calibration views with it (:mod:`morf.export.export_avatar`) and playback every frame
(:mod:`morf.playback.player`), so it sits below both.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from morf.camera import GL_FRONT_FACE
from morf.raster.gl_context import software_gl
from morf.raster.texture_quant import ZERO_POINT, QuantizedTexture
from morf.records import length_of
from morf.resources import shader_source

NEAR, FAR = 0.05, 100.0  # the same clip planes as the training rasterizer (morf.raster.gl_buffers)
NUM_CHANNELS = 16
# Renderer input layouts: "nhwc" (1, H, W, 16) is the read-back as it is (onnxruntime's int8
# convolutions run channels last, so the graph's leading Transpose cancels against theirs);
# "nchw" (1, 16, H, W); "planes" (4, H, W, 4), an older four-attachment rasterizer's read-back.
LAYOUTS = ("nhwc", "nchw", "planes")
# moderngl clears every attachment from four floats and hands their bits to integer attachments:
# the float whose bits are 0x80808080 clears each byte of the RGBA32UI attachment to the zero point.
_CLEAR_WORD = struct.unpack("<f", bytes([ZERO_POINT] * 4))[0]
# On the body this channel's byte is never the zero point (neural_raster_fs.glsl); off it every byte is.
COVERAGE_CHANNEL = 0


@dataclass(frozen=True)
class SkinnedMesh:
    """The render mesh as the player needs it.

    Fields:
        rest_vertices: (Vr, 3) float32 shaped rest-pose vertices (seams split).
        uvs: (Vr, 2) float32 texture coordinates, v up.
        faces: (F, 3) int32 triangles.
        bone_indices: (Vr, 8) int32 bones per vertex; bone_weights: (Vr, 8) float32 (rows sum to 1).
    """

    rest_vertices: np.ndarray
    uvs: np.ndarray
    faces: np.ndarray
    bone_indices: np.ndarray
    bone_weights: np.ndarray

    num_vertices = length_of("rest_vertices")


def _skin_on_cpu(ctx) -> bool:
    """Skin with numba on the CPU where GL itself runs on the CPU (Mesa's llvmpipe runs vertex
    shaders on one thread: 2 ms of a 640x640 frame against 0.12 ms for the loop); on a GPU the
    vertex shader skins for free."""
    from morf.machine.compiled import numba_available  # the machine probes load only when asked

    return numba_available() and software_gl(ctx)


class NeuralRasterizer:
    """Renders the 16-channel neural rasterization of a posed mesh into one RGBA32UI attachment.

    Args:
        ctx: a moderngl context (headless or a window's); every call must happen where it is current.
        mesh: :class:`SkinnedMesh`; texture: :class:`QuantizedTexture` with 16 channels.
        width, height: framebuffer size in pixels; num_bones: J of the skeleton.
        cpu_skinning: skin the mesh with numba on the CPU and only project in the vertex shader
            (True), or skin in the vertex shader (False); None: on the CPU where the GL is
            software (llvmpipe) and numba imports, in the shader on a GPU.
    """

    def __init__(self, ctx, mesh: SkinnedMesh, texture: QuantizedTexture, width: int, height: int, num_bones: int,
                 cpu_skinning: bool | None = None):
        if texture.channels != NUM_CHANNELS:
            raise ValueError(f"the GL rasterizer expects a {NUM_CHANNELS}-channel texture, got {texture.channels}")
        if mesh.bone_indices.shape[1] != 8:
            raise ValueError("the skinning shader takes exactly 8 bones per vertex")
        self.ctx, self.width, self.height, self.num_bones = ctx, int(width), int(height), int(num_bones)
        self.cpu_skinning = _skin_on_cpu(ctx) if cpu_skinning is None else bool(cpu_skinning)
        self._index = ctx.buffer(np.ascontiguousarray(mesh.faces, np.int32).tobytes())
        uv = ctx.buffer(np.ascontiguousarray(mesh.uvs, np.float32).tobytes())
        if self.cpu_skinning:  # skinned by numba each frame; the shader only projects
            self._rest = np.ascontiguousarray(mesh.rest_vertices, np.float32)
            self._bone_indices = np.ascontiguousarray(mesh.bone_indices, np.int32)
            self._bone_weights = np.ascontiguousarray(mesh.bone_weights, np.float32)
            self._posed = np.empty_like(self._rest)
            self.program = ctx.program(vertex_shader=shader_source("neural_raster_posed_vs.glsl"),
                                       fragment_shader=shader_source("neural_raster_fs.glsl"))
            pos = ctx.buffer(reserve=self._posed.nbytes, dynamic=True)
            self._buffers = [pos, uv]
            self.vao = ctx.vertex_array(self.program, [(pos, "3f", "in_position"), (uv, "2f", "in_uv")],
                                        index_buffer=self._index, index_element_size=4)
        else:
            self.program = ctx.program(vertex_shader=shader_source("neural_raster_vs.glsl", {"NUM_BONES": num_bones}),
                                       fragment_shader=shader_source("neural_raster_fs.glsl"))
            self._buffers = [
                ctx.buffer(np.ascontiguousarray(mesh.rest_vertices, np.float32).tobytes()), uv,
                ctx.buffer(np.ascontiguousarray(mesh.bone_indices, np.int32).tobytes()),
                ctx.buffer(np.ascontiguousarray(mesh.bone_weights, np.float32).tobytes()),
            ]
            pos, uv, bi, bw = self._buffers
            self.vao = ctx.vertex_array(self.program, [(pos, "3f", "in_position"), (uv, "2f", "in_uv"),
                                                       (bi, "4i 4i", "in_bones0", "in_bones1"),
                                                       (bw, "4f 4f", "in_weights0", "in_weights1")],
                                        index_buffer=self._index, index_element_size=4)
        Ht, Wt, _ = texture.data.shape
        self._texture_bytes, self._channel3 = texture.data, None
        self.textures = []
        for i in range(NUM_CHANNELS // 4):
            tex = ctx.texture((Wt, Ht), 4, np.ascontiguousarray(texture.data[..., 4 * i:4 * i + 4]).tobytes())
            tex.filter = (ctx.LINEAR, ctx.LINEAR)  # bilinear, no mipmaps: what grid_sample does
            tex.repeat_x = tex.repeat_y = False  # clamp to edge = grid_sample padding_mode="border"
            self.textures.append(tex)
            self.program[f"u_texture{i}"].value = i
        self.attachment = ctx.texture((self.width, self.height), 4, dtype="u4")
        self._depth = ctx.depth_renderbuffer((self.width, self.height))
        self.fbo = ctx.framebuffer(color_attachments=[self.attachment], depth_attachment=self._depth)

    def set_colour(self, rgb: np.ndarray) -> None:
        """Replace the texture's channels 0-2 (bytes (Ht, Wt, 3)) for the frames drawn from now on
        (view colours, :mod:`morf.avatar.view_colour`); channel 3 stays as loaded."""
        if self._channel3 is None:
            self._channel3 = np.ascontiguousarray(self._texture_bytes[..., 3:4])
        rgba = np.concatenate([np.asarray(rgb, np.uint8), self._channel3], axis=2)
        self.textures[0].write(np.ascontiguousarray(rgba).tobytes())

    def draw(self, bone_transforms: np.ndarray, camera) -> None:
        """Render one frame into :attr:`fbo`.

        Args:
            bone_transforms: (J, 4, 4) skinning matrices (see :meth:`SkinningSkeleton.bone_transforms`).
            camera: a :class:`morf.camera.PinholeCamera` (or anything with ``width``, ``height``,
                ``view_matrix()`` and ``gl_projection(near, far)``) of this rasterizer's size.
        """
        if (camera.width, camera.height) != (self.width, self.height):
            raise ValueError(f"camera is {camera.width}x{camera.height}, rasterizer {self.width}x{self.height}")
        T = np.asarray(bone_transforms, np.float32)
        if T.shape != (self.num_bones, 4, 4):
            raise ValueError(f"bone transforms must be ({self.num_bones}, 4, 4), got {T.shape}")
        ctx = self.ctx
        if self.cpu_skinning:
            from morf.raster.skinning_kernels import skin

            skin(self._rest, self._bone_indices, self._bone_weights, np.ascontiguousarray(T), self._posed)
            self._buffers[0].write(self._posed)
        else:  # GLSL matrices are column-major: write each matrix transposed.
            self.program["u_bones"].write(np.ascontiguousarray(T.transpose(0, 2, 1)).tobytes())
        vp = camera.gl_projection(NEAR, FAR).astype(np.float32) @ camera.view_matrix().astype(np.float32)
        self.program["u_view_proj"].write(np.ascontiguousarray(vp.T, np.float32).tobytes())
        for i, tex in enumerate(self.textures):
            tex.use(i)
        self.fbo.use()
        ctx.viewport = (0, 0, self.width, self.height)
        ctx.disable(ctx.BLEND)
        # Back faces are culled: hidden behind front faces on the closed body, so the image is the
        # same (identical on 30 views around the body) and llvmpipe shades ~25% fewer fragments.
        # gl_projection flips y, which turns the mesh's counter-clockwise front faces clockwise.
        ctx.enable(ctx.DEPTH_TEST | ctx.CULL_FACE)
        ctx.front_face, ctx.cull_face = GL_FRONT_FACE, "back"
        self.fbo.clear(_CLEAR_WORD, _CLEAR_WORD, _CLEAR_WORD, _CLEAR_WORD, depth=1.0)
        self.vao.render()
        ctx.disable(ctx.CULL_FACE)  # the GL default, for whoever draws next in a shared context
        ctx.front_face = "ccw"

    def read(self, out: np.ndarray | None = None) -> np.ndarray:
        """Read the attachment into (H, W, 16) uint8 (channels last; row 0 = image row 0, as
        ``gl_projection`` flips y). ``out`` (any C-contiguous uint8 array of H*W*16 bytes, e.g.
        the renderer's (1, H, W, 16) input) is filled in place when given."""
        if out is None:
            out = np.empty((self.height, self.width, NUM_CHANNELS), np.uint8)
        if not (out.flags.c_contiguous and out.dtype == np.uint8 and out.size == self.height * self.width * NUM_CHANNELS):
            raise ValueError("read buffer must be C-contiguous uint8 with H*W*16 elements")
        self.fbo.read_into(out, components=4, dtype="u4", alignment=1)
        return out

    def release(self) -> None:
        for obj in [self.vao, self.program, self.fbo, self._depth, self._index, *self._buffers, *self.textures,
                    self.attachment]:
            obj.release()


def to_layout(hwc: np.ndarray, layout: str, out: np.ndarray | None = None) -> np.ndarray:
    """(H, W, 16) read-back -> the renderer input in ``layout``: "nhwc" (1, H, W, 16), a view;
    "nchw" (1, 16, H, W) or "planes" (4, H, W, 4, the layout of an older four-attachment
    rasterizer), copies (into ``out`` when given)."""
    H, W, C = hwc.shape
    if layout == "nhwc":
        return hwc.reshape(1, H, W, C)
    if layout == "nchw":
        src, shape = hwc.transpose(2, 0, 1)[None], (1, C, H, W)
    elif layout == "planes":
        src, shape = hwc.reshape(H, W, C // 4, 4).transpose(2, 0, 1, 3), (C // 4, H, W, 4)
    else:
        raise ValueError(f"unknown renderer input layout {layout!r}; choose one of {', '.join(LAYOUTS)}")
    if out is None:
        out = np.empty(shape, np.uint8)
    out[...] = src
    return out


def mark_coverage(raster: np.ndarray, channel_axis: int) -> np.ndarray:
    """The coverage mark of the GL rasterizer on a uint8 raster made elsewhere, in place: where
    a pixel has any byte off the zero point (on the body) and its :data:`COVERAGE_CHANNEL` byte
    is the zero point, that byte becomes zero point + 1, as the shader writes it. Returns ``raster``."""
    covered = (raster != ZERO_POINT).any(axis=channel_axis)
    byte = np.take(raster, COVERAGE_CHANNEL, axis=channel_axis)
    fix = covered & (byte == ZERO_POINT)
    index = [slice(None)] * raster.ndim
    index[channel_axis] = COVERAGE_CHANNEL
    raster[tuple(index)] = np.where(fix, ZERO_POINT + 1, byte)
    return raster
