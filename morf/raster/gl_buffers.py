"""GL-side copies of a render mesh and the camera matrices, shared by the mesh rasterizers.

The topology (index buffer, UVs) is uploaded once per mesh and context; only the vertex
positions (and normals, for shading) change per frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.body.render_mesh import RenderMesh
from morf.camera import PinholeCamera
from morf.errors import InputError
from morf.raster.gl_context import GLState

NEAR, FAR = 0.05, 100.0


@dataclass(frozen=True)
class MeshBuffers:
    """GL buffers of one render mesh in one context.

    Fields:
        mesh: the RenderMesh they were made from (kept so a recycled ``id`` cannot alias).
        index: (F*3,) int32 triangle corner indices.
        uv: (Vr, 2) float32 texture coordinates.
        position: (Vr, 3) float32 world positions, rewritten every frame.
        normal: (Vr, 3) float32 world normals, rewritten when shading.
    """

    mesh: RenderMesh
    index: object
    uv: object
    position: object
    normal: object

    def release(self) -> None:
        for b in (self.index, self.uv, self.position, self.normal):
            b.release()


def mesh_buffers(state: GLState, mesh: RenderMesh) -> MeshBuffers:
    """The context's buffers for ``mesh`` (made on first use; a few meshes are kept)."""
    key = ("mesh", id(mesh))
    bufs = state.cached(key, lambda: _make_buffers(state, mesh))
    if bufs.mesh is not mesh:  # a different mesh now lives at the same id
        state.drop(key)
        bufs = state.cached(key, lambda: _make_buffers(state, mesh))
    mesh_keys = [k for k in state.keys() if isinstance(k, tuple) and k[0] == "mesh"]
    for old in mesh_keys[:-4]:  # bound the cache: keep the 4 most recent meshes
        for k in state.keys():
            if isinstance(k, tuple) and k[0] == "vao" and k[2] == old[1]:
                state.drop(k)
        state.drop(old)
    return bufs


def mesh_vao(state: GLState, mesh: RenderMesh, program, name: str, attributes: list[tuple[str, str]]):
    """A cached vertex array binding ``mesh``'s buffers to ``program``.

    ``attributes`` lists (buffer field of :class:`MeshBuffers`, GLSL input name), e.g.
    ``[("position", "in_pos"), ("uv", "in_uv")]``.
    """
    bufs = mesh_buffers(state, mesh)
    key = ("vao", name, id(mesh))
    fmt = {"position": "3f", "normal": "3f", "uv": "2f"}

    def make():
        content = [(getattr(bufs, field), fmt[field], glsl) for field, glsl in attributes]
        return _BoundVAO(bufs, state.ctx.vertex_array(program, content, index_buffer=bufs.index,
                                                      index_element_size=4))

    bound = state.cached(key, make)
    if bound.buffers is not bufs:  # the mesh buffers were rebuilt: rebind
        state.drop(key)
        bound = state.cached(key, make)
    return bound.vao


class _BoundVAO:
    """A vertex array and the buffers it reads; releasing it leaves the buffers alone."""

    def __init__(self, buffers: MeshBuffers, vao):
        self.buffers, self.vao = buffers, vao

    def release(self) -> None:
        self.vao.release()


def _make_buffers(state: GLState, mesh: RenderMesh) -> MeshBuffers:
    ctx = state.ctx
    n = mesh.num_vertices
    return MeshBuffers(
        mesh=mesh,
        index=ctx.buffer(np.ascontiguousarray(mesh.faces, dtype=np.int32).tobytes()),
        uv=ctx.buffer(np.ascontiguousarray(mesh.uvs, dtype=np.float32).tobytes()),
        position=ctx.buffer(reserve=n * 12, dynamic=True),
        normal=ctx.buffer(reserve=n * 12, dynamic=True),
    )


def as_vertices(vertices, mesh: RenderMesh) -> np.ndarray:
    """(Vr, 3) numpy or torch render-mesh vertices -> contiguous float32 numpy."""
    if hasattr(vertices, "detach"):
        vertices = vertices.detach().cpu().numpy()
    v = np.ascontiguousarray(vertices, dtype=np.float32)
    if v.shape != (mesh.num_vertices, 3):
        raise InputError(f"vertices must be ({mesh.num_vertices}, 3) render-mesh vertices, got {v.shape}")
    return v


def camera_uniforms(camera: PinholeCamera) -> dict[str, bytes]:
    """Column-major float32 bytes of the view and projection matrices for GLSL ``mat4``."""
    view = camera.view_matrix().astype(np.float32)
    proj = camera.gl_projection(NEAR, FAR).astype(np.float32)
    return {"view": view.T.tobytes(), "proj": proj.T.tobytes()}


def set_uniforms(program, values: dict) -> None:
    """Write uniforms that the (optimising) GLSL compiler kept; bytes are written raw."""
    for name, value in values.items():
        if name not in program:
            continue
        if isinstance(value, bytes):
            program[name].write(value)
        else:
            program[name].value = value
