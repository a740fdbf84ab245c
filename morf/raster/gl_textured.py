"""Textured colour rendering of a posed render mesh (synthetic frames, previews).

Bilinear filtering with mipmaps and multisampling, so a high-frequency clothing print looks
like a photographed one rather than aliased texels. Optional Lambert shading from smooth
normals makes the body read as 3D.
"""

from __future__ import annotations

import numpy as np

from morf.body.render_mesh import RenderMesh
from morf.camera import PinholeCamera
from morf.errors import InputError
from morf.raster.gl_buffers import as_vertices, camera_uniforms, mesh_buffers, mesh_vao, set_uniforms
from morf.raster.gl_context import GLState, current, gl_state, with_gl_context
from morf.resources import shader_stages


# Light from slightly above the camera (camera y points down, the camera looks along +z).
_DEFAULT_LIGHT_CAM = (0.0, -0.45, -1.0)


class GLTexture:
    """An RGB texture uploaded to the calling thread's context, with mipmaps.

    Make one with :func:`upload_texture` to reuse it over many frames; ``render_textured``
    also accepts a plain array and uploads it each call.
    """

    def __init__(self, state: GLState, image: np.ndarray):
        image = _check_texture(image)
        self.state = state
        self.size = (image.shape[1], image.shape[0])
        self.tex = state.ctx.texture(self.size, 3, np.ascontiguousarray(image).tobytes(), alignment=1)
        self.tex.build_mipmaps()
        self.tex.filter = (state.ctx.LINEAR_MIPMAP_LINEAR, state.ctx.LINEAR)
        self.tex.anisotropy = 4.0  # sharp prints at grazing angles; 8 costs llvmpipe much more
        self.tex.repeat_x = self.tex.repeat_y = False

    def release(self) -> None:
        with current(self.state):
            self.tex.release()


@with_gl_context
def upload_texture(image: np.ndarray) -> GLTexture:
    """Upload an (Ht, Wt, 3) uint8 RGB texture (row 0 = top = v 1) for :func:`render_textured`."""
    return GLTexture(gl_state(), image)


def _check_texture(image) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
        raise InputError(f"texture must be (H, W, 3) uint8, got {image.shape} {image.dtype}")
    return image


def render_mesh_normals(vertices: np.ndarray, mesh: RenderMesh) -> np.ndarray:
    """(Vr, 3) area-weighted unit vertex normals, smooth across UV seams.

    Face normals are summed per *model* vertex (through ``mesh.vertex_map``) so the copies of
    a seam vertex share one normal and the shading shows no seam.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = mesh.faces
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    model_idx = mesh.vertex_map[f].reshape(-1)
    n_model = int(mesh.vertex_map.max()) + 1
    acc = np.stack([np.bincount(model_idx, np.repeat(fn[:, k], 3), minlength=n_model) for k in range(3)], 1)
    n = acc[mesh.vertex_map]
    n /= np.clip(np.linalg.norm(n, axis=1, keepdims=True), 1e-12, None)
    return n.astype(np.float32)


def _program(state: GLState):
    return state.cached(("program", "textured"),
                        lambda: state.ctx.program(**shader_stages("gl_textured")))


def _framebuffers(state: GLState, width: int, height: int, samples: int):
    """(draw framebuffer, resolve framebuffer); the same one twice without multisampling."""
    ctx = state.ctx

    def make():
        resolve = ctx.framebuffer(color_attachments=[ctx.renderbuffer((width, height), 4)],
                                  depth_attachment=ctx.depth_renderbuffer((width, height)))
        if samples <= 1:
            return _FBOPair(resolve, resolve)
        draw = ctx.framebuffer(color_attachments=[ctx.renderbuffer((width, height), 4, samples=samples)],
                               depth_attachment=ctx.depth_renderbuffer((width, height), samples=samples))
        return _FBOPair(draw, resolve)

    return state.cached(("fbo", "textured", width, height, samples), make)


class _FBOPair:
    def __init__(self, draw, resolve):
        self.draw, self.resolve = draw, resolve

    def release(self) -> None:
        self.resolve.release()
        if self.draw is not self.resolve:
            self.draw.release()


@with_gl_context
def render_textured(vertices, mesh: RenderMesh, camera: PinholeCamera, texture,
                    background=(0, 0, 0), msaa: int = 4, shading: float = 0.0,
                    uvs: np.ndarray | None = None, light_dir_cam=_DEFAULT_LIGHT_CAM) -> tuple[np.ndarray, np.ndarray]:
    """Render a textured, optionally shaded mesh.

    Args:
        vertices: (Vr, 3) numpy or torch world-space render-mesh vertices.
        mesh: the render mesh.
        camera: the camera; the image is ``camera.height`` x ``camera.width``.
        texture: (Ht, Wt, 3) uint8 RGB atlas (row 0 = v 1) or a :class:`GLTexture`.
        background: (r, g, b) 0-255 colour behind the person.
        msaa: samples per pixel (0 or 1: none).
        shading: 0 = flat albedo, 1 = full Lambert shading from ``light_dir_cam``.
        uvs: optional (Vr, 2) per-vertex texture coordinates replacing ``mesh.uvs`` for this
            frame (e.g. cloth sliding); same convention.
        light_dir_cam: direction towards the light in camera coordinates.
    Returns:
        rgb (H, W, 3) uint8 and mask (H, W) bool (at least half of the pixel covered).
    """
    state = gl_state()
    ctx = state.ctx
    samples = max(1, min(int(msaa), ctx.max_samples))
    verts = as_vertices(vertices, mesh)
    prog = _program(state)
    bufs = mesh_buffers(state, mesh)
    bufs.position.write(verts.tobytes())
    if "in_normal" in prog:
        bufs.normal.write(render_mesh_normals(verts, mesh).tobytes())
    attrs = [("position", "in_pos"), ("uv", "in_uv")] + ([("normal", "in_normal")] if "in_normal" in prog else [])
    vao = mesh_vao(state, mesh, prog, "textured", attrs)
    if uvs is not None:
        uv = np.ascontiguousarray(uvs, dtype=np.float32)
        if uv.shape != (mesh.num_vertices, 2):
            raise InputError(f"uvs must be ({mesh.num_vertices}, 2), got {uv.shape}")
        bufs.uv.write(uv.tobytes())

    own_texture = not isinstance(texture, GLTexture)
    tex = GLTexture(state, texture) if own_texture else texture
    try:
        light = np.asarray(light_dir_cam, dtype=np.float64)
        light = light / np.linalg.norm(light)
        set_uniforms(prog, {**camera_uniforms(camera), "shading": float(shading),
                            "light_cam": tuple(float(x) for x in light), "tex": 0})
        tex.tex.use(0)
        fbos = _framebuffers(state, camera.width, camera.height, samples)
        fbos.draw.use()
        ctx.viewport = (0, 0, camera.width, camera.height)
        ctx.disable(ctx.BLEND | ctx.CULL_FACE)
        ctx.enable(ctx.DEPTH_TEST)
        bg = np.asarray(background, dtype=np.float64) / 255.0
        fbos.draw.clear(float(bg[0]), float(bg[1]), float(bg[2]), 0.0, depth=1.0)
        vao.render()
        if fbos.draw is not fbos.resolve:
            ctx.copy_framebuffer(fbos.resolve, fbos.draw)
        raw = np.frombuffer(fbos.resolve.read(components=4, alignment=1), dtype=np.uint8)
    finally:
        if uvs is not None:  # the shared UV buffer goes back to the mesh's own UVs
            bufs.uv.write(np.ascontiguousarray(mesh.uvs, dtype=np.float32).tobytes())
        if own_texture:
            tex.release()
    rgba = raw.reshape(camera.height, camera.width, 4)
    return np.ascontiguousarray(rgba[..., :3]), rgba[..., 3] >= 128
