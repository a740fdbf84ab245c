"""Live neural rasterization in OpenGL: GPU skinning + 16-channel uint8 texture lookup.

What the paper's phone app does per frame: skin the render mesh in the vertex shader from the
frame's bone matrices, sample the quantised neural texture (four RGBA8 textures, bilinear) and
write the 16 channels, still 8-bit, to four RGBA8 colour attachments cleared to 128 (= 0).
Reading the attachments back gives the int8 renderer's input without any float conversion.

Torch-free on purpose (numpy + moderngl): an exported avatar plays without torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.export.texture_quant import ZERO_POINT, QuantizedTexture

SHADER_DIR = Path(__file__).resolve().parents[2] / "resources" / "shaders"
NEAR, FAR = 0.05, 100.0  # the same clip planes as the training rasterizer (morf.raster.gl_buffers)
NUM_CHANNELS = 16


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

    @property
    def num_vertices(self) -> int:
        return int(self.rest_vertices.shape[0])


def load_shader(name: str) -> str:
    return (SHADER_DIR / name).read_text()


def create_headless_context():
    """A standalone moderngl context on EGL (Mesa llvmpipe without a GPU)."""
    import moderngl

    from morf.errors import MorfError

    try:
        return moderngl.create_standalone_context(backend="egl")
    except Exception as e:  # moderngl raises plain Exception for EGL failures
        raise MorfError(f"cannot create a headless OpenGL context through EGL ({e}); "
                        "install the system packages libegl1 and libgl1") from None


class NeuralRasterizer:
    """Renders the 16-channel neural rasterization of a posed mesh into four RGBA8 attachments.

    Args:
        ctx: a moderngl context (headless or a window's); every call must happen where it is current.
        mesh: :class:`SkinnedMesh`; texture: :class:`QuantizedTexture` with 16 channels.
        width, height: framebuffer size in pixels; num_bones: J of the skeleton.
    """

    def __init__(self, ctx, mesh: SkinnedMesh, texture: QuantizedTexture, width: int, height: int, num_bones: int):
        if texture.channels != NUM_CHANNELS:
            raise ValueError(f"the GL rasterizer expects a {NUM_CHANNELS}-channel texture, got {texture.channels}")
        if mesh.bone_indices.shape[1] != 8:
            raise ValueError("the skinning shader takes exactly 8 bones per vertex")
        self.ctx, self.width, self.height, self.num_bones = ctx, int(width), int(height), int(num_bones)
        vs = load_shader("neural_raster_vs.glsl").replace("#version 330 core", f"#version 330 core\n#define NUM_BONES {num_bones}", 1)
        self.program = ctx.program(vertex_shader=vs, fragment_shader=load_shader("neural_raster_fs.glsl"))
        self._buffers = [
            ctx.buffer(np.ascontiguousarray(mesh.rest_vertices, np.float32).tobytes()),
            ctx.buffer(np.ascontiguousarray(mesh.uvs, np.float32).tobytes()),
            ctx.buffer(np.ascontiguousarray(mesh.bone_indices, np.int32).tobytes()),
            ctx.buffer(np.ascontiguousarray(mesh.bone_weights, np.float32).tobytes()),
        ]
        self._index = ctx.buffer(np.ascontiguousarray(mesh.faces, np.int32).tobytes())
        pos, uv, bi, bw = self._buffers
        self.vao = ctx.vertex_array(self.program, [(pos, "3f", "in_position"), (uv, "2f", "in_uv"),
                                                   (bi, "4i 4i", "in_bones0", "in_bones1"),
                                                   (bw, "4f 4f", "in_weights0", "in_weights1")],
                                    index_buffer=self._index, index_element_size=4)
        Ht, Wt, _ = texture.data.shape
        self.textures = []
        for i in range(NUM_CHANNELS // 4):
            tex = ctx.texture((Wt, Ht), 4, np.ascontiguousarray(texture.data[..., 4 * i:4 * i + 4]).tobytes())
            tex.filter = (ctx.LINEAR, ctx.LINEAR)  # bilinear, no mipmaps: what grid_sample does
            tex.repeat_x = tex.repeat_y = False  # clamp to edge = grid_sample padding_mode="border"
            self.textures.append(tex)
            self.program[f"u_texture{i}"].value = i
        self.attachments = [ctx.texture((self.width, self.height), 4) for _ in range(NUM_CHANNELS // 4)]
        self._depth = ctx.depth_renderbuffer((self.width, self.height))
        self.fbo = ctx.framebuffer(color_attachments=self.attachments, depth_attachment=self._depth)

    def draw(self, bone_transforms: np.ndarray, camera) -> None:
        """Render one frame into :attr:`fbo`.

        Args:
            bone_transforms: (J, 4, 4) skinning matrices (see :meth:`Skeleton.bone_transforms`).
            camera: a :class:`morf.camera.PinholeCamera` (or anything with ``width``, ``height``,
                ``view_matrix()`` and ``gl_projection(near, far)``) of this rasterizer's size.
        """
        if (camera.width, camera.height) != (self.width, self.height):
            raise ValueError(f"camera is {camera.width}x{camera.height}, rasterizer {self.width}x{self.height}")
        T = np.asarray(bone_transforms, np.float32)
        if T.shape != (self.num_bones, 4, 4):
            raise ValueError(f"bone transforms must be ({self.num_bones}, 4, 4), got {T.shape}")
        ctx = self.ctx
        # GLSL matrices are column-major: write each matrix transposed.
        self.program["u_bones"].write(np.ascontiguousarray(T.transpose(0, 2, 1)).tobytes())
        vp = camera.gl_projection(NEAR, FAR).astype(np.float32) @ camera.view_matrix().astype(np.float32)
        self.program["u_view_proj"].write(np.ascontiguousarray(vp.T, np.float32).tobytes())
        for i, tex in enumerate(self.textures):
            tex.use(i)
        self.fbo.use()
        ctx.viewport = (0, 0, self.width, self.height)
        ctx.disable(ctx.BLEND | ctx.CULL_FACE)
        ctx.enable(ctx.DEPTH_TEST)
        z = ZERO_POINT / 255.0
        self.fbo.clear(z, z, z, z, depth=1.0)
        self.vao.render()

    def read(self, out: np.ndarray | None = None) -> np.ndarray:
        """Read the four attachments into (4, H, W, 4) uint8 (channel 4*i+k = out[i, ..., k]).

        Row 0 is image row 0 (``gl_projection`` flips y). ``out`` is reused when given.
        """
        if out is None:
            out = np.empty((4, self.height, self.width, 4), np.uint8)
        plane = self.height * self.width * 4
        for i in range(len(self.attachments)):
            self.fbo.read_into(out, components=4, attachment=i, alignment=1, write_offset=i * plane)
        return out

    def release(self) -> None:
        for obj in [self.vao, self.program, self.fbo, self._depth, self._index, *self._buffers, *self.textures,
                    *self.attachments]:
            obj.release()


def planes_to_nchw(planes: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """(4, H, W, 4) read-back planes -> (1, 16, H, W) uint8 (channel 4*i+k)."""
    _, H, W, _ = planes.shape
    if out is None:
        out = np.empty((1, 16, H, W), np.uint8)
    out.reshape(4, 4, H, W)[...] = planes.transpose(0, 3, 1, 2)
    return out
