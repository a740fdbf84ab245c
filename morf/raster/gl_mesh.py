"""UV rasterization of a posed render mesh: the per-pixel texture coordinates a neural texture
is sampled with.

One exact sample per pixel centre (no multisampling), so pixel (x, y) of the result is the
surface seen through the point (x + 0.5, y + 0.5) of :meth:`PinholeCamera.project`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.body.render_mesh import RenderMesh
from morf.camera import PinholeCamera
from morf.raster.gl_buffers import as_vertices, camera_uniforms, mesh_buffers, mesh_vao, set_uniforms
from morf.raster.gl_context import GLState, gl_state, with_gl_context
from morf.resources import shader_stages


@dataclass(frozen=True)
class Rasterization:
    """What each pixel sees. Arrays carry a leading (B,) axis when made by the batched helper.

    Fields:
        uv: (H, W, 2) float32 texture coordinates, same convention as ``RenderMesh.uvs``
            (v up); 0 on background.
        mask: (H, W) bool, True where a triangle covers the pixel centre.
        face_id: (H, W) int32 index into ``RenderMesh.faces``; -1 on background.
        depth: (H, W) float32 camera-space z (metres along the view axis); 0 on background.
    """

    uv: np.ndarray
    mask: np.ndarray
    face_id: np.ndarray
    depth: np.ndarray


def _program(state: GLState):
    return state.cached(("program", "uv"), lambda: state.ctx.program(**shader_stages("gl_mesh")))


def _framebuffer(state: GLState, width: int, height: int):
    def make():
        ctx = state.ctx
        return ctx.framebuffer(color_attachments=[ctx.texture((width, height), 4, dtype="f4")],
                               depth_attachment=ctx.depth_renderbuffer((width, height)))

    return state.cached(("fbo", "uv", width, height), make)


def _rasterize_one(state: GLState, verts: np.ndarray, mesh: RenderMesh, camera: PinholeCamera,
                   vao, prog, fbo) -> Rasterization:
    ctx = state.ctx
    bufs = mesh_buffers(state, mesh)
    bufs.position.write(verts.tobytes())
    set_uniforms(prog, camera_uniforms(camera))
    fbo.use()
    ctx.viewport = (0, 0, camera.width, camera.height)
    ctx.disable(ctx.BLEND | ctx.CULL_FACE)
    ctx.enable(ctx.DEPTH_TEST)
    fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
    vao.render()
    raw = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
    # Row 0 of the read-back is framebuffer y = 0, which gl_projection maps to image row 0.
    attr = raw.reshape(camera.height, camera.width, 4)
    face_id = attr[..., 3].astype(np.int32) - 1
    return Rasterization(uv=np.ascontiguousarray(attr[..., :2]), mask=face_id >= 0, face_id=face_id,
                         depth=np.ascontiguousarray(attr[..., 2]))


def _vao(state: GLState, mesh: RenderMesh, prog):
    return mesh_vao(state, mesh, prog, "uv", [("position", "in_pos"), ("uv", "in_uv")])


@with_gl_context
def rasterize_uv(vertices, mesh: RenderMesh, camera: PinholeCamera) -> Rasterization:
    """Rasterize one posed render mesh.

    Args:
        vertices: (Vr, 3) numpy or torch world-space render-mesh vertices (``mesh.gather`` of
            the body model's vertices).
        mesh: the render mesh (topology and UVs).
        camera: the camera; the result is ``camera.height`` x ``camera.width``.
    Returns:
        :class:`Rasterization` with (H, W) maps.
    """
    state = gl_state()
    prog = _program(state)
    return _rasterize_one(state, as_vertices(vertices, mesh), mesh, camera, _vao(state, mesh, prog), prog,
                          _framebuffer(state, camera.width, camera.height))


@with_gl_context
def rasterize_uv_batch(vertices, mesh: RenderMesh, cameras) -> Rasterization:
    """Rasterize B frames; ``cameras`` is one camera for all or a sequence of B (same size).

    Args:
        vertices: (B, Vr, 3) numpy or torch.
    Returns:
        :class:`Rasterization` whose arrays have a leading (B,) axis.
    """
    B = len(vertices)
    if B == 0:
        raise ValueError("rasterize_uv_batch needs at least one frame")
    cams = [cameras] * B if isinstance(cameras, PinholeCamera) else list(cameras)
    if len(cams) != B:
        raise ValueError(f"{B} frames but {len(cams)} cameras")
    if len({(c.width, c.height) for c in cams}) > 1:
        raise ValueError("all cameras of a batch must have the same image size")
    state = gl_state()
    prog = _program(state)
    vao = _vao(state, mesh, prog)
    out = []
    for b in range(B):
        fbo = _framebuffer(state, cams[b].width, cams[b].height)
        out.append(_rasterize_one(state, as_vertices(vertices[b], mesh), mesh, cams[b], vao, prog, fbo))
    return Rasterization(*(np.stack([getattr(r, f) for r in out]) for f in ("uv", "mask", "face_id", "depth")))
