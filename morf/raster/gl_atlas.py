"""Baking per-vertex attributes into the UV atlas (rasterizing the mesh in texture space).

Used to paint procedural textures (each texel learns the rest-pose position, body part, ... of
the surface point it covers) and to see which texels the atlas uses at all.
"""

from __future__ import annotations

import numpy as np

from morf.body.render_mesh import RenderMesh
from morf.raster.gl_context import GLState, gl_state, with_gl_context
from morf.resources import shader_stages


def _program(state: GLState):
    return state.cached(("program", "atlas"), lambda: state.ctx.program(**shader_stages("gl_atlas")))


@with_gl_context
def bake_vertex_attributes(mesh: RenderMesh, attributes: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Interpolate per-vertex values over the UV atlas, one sample per texel centre.

    Args:
        mesh: render mesh (its ``uvs`` place each vertex in the atlas).
        attributes: (Vr, C) float values per render vertex.
        size: atlas resolution (size x size texels).
    Returns:
        values (size, size, C) float32, texture row 0 = v 1 (zero outside the charts), and
        coverage (size, size) bool, the texels that some triangle covers.
    """
    attrs = np.asarray(attributes, dtype=np.float32)
    if attrs.ndim != 2 or attrs.shape[0] != mesh.num_vertices:
        raise ValueError(f"attributes must be ({mesh.num_vertices}, C), got {attrs.shape}")
    state = gl_state()
    ctx = state.ctx
    prog = _program(state)
    index = ctx.buffer(np.ascontiguousarray(mesh.faces, dtype=np.int32).tobytes())
    uv = ctx.buffer(np.ascontiguousarray(mesh.uvs, dtype=np.float32).tobytes())
    color = ctx.texture((size, size), 4, dtype="f4")
    cover = ctx.texture((size, size), 1, dtype="f1")
    fbo = ctx.framebuffer(color_attachments=[color, cover])
    C = attrs.shape[1]
    out = np.zeros((size, size, C), np.float32)
    coverage = None
    try:
        fbo.use()
        ctx.viewport = (0, 0, size, size)
        ctx.disable(ctx.BLEND | ctx.DEPTH_TEST | ctx.CULL_FACE)
        for start in range(0, C, 4):  # four channels per pass
            chunk = np.zeros((mesh.num_vertices, 4), np.float32)
            chunk[:, :min(4, C - start)] = attrs[:, start:start + 4]
            buf = ctx.buffer(chunk.tobytes())
            vao = ctx.vertex_array(prog, [(uv, "2f", "in_uv"), (buf, "4f", "in_attr")],
                                   index_buffer=index, index_element_size=4)
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            vao.render()
            vals = np.frombuffer(fbo.read(components=4, dtype="f4", attachment=0), np.float32)
            out[..., start:start + 4] = vals.reshape(size, size, 4)[..., :min(4, C - start)]
            if coverage is None:
                cov = np.frombuffer(fbo.read(components=1, attachment=1, alignment=1), np.uint8)
                coverage = cov.reshape(size, size) > 0
            vao.release()
            buf.release()
    finally:
        for obj in (fbo, color, cover, uv, index):
            obj.release()
    return out, coverage


def dilate_charts(image: np.ndarray, coverage: np.ndarray, iterations: int = 8) -> np.ndarray:
    """Grow each UV chart's colours ``iterations`` texels into the empty atlas around it.

    Mipmapped and bilinear lookups near a chart border (and slightly shifted UVs) then read
    the chart's own colours instead of the empty background.

    Args:
        image: (H, W, C) float or uint8; coverage: (H, W) bool texels that hold real values.
    """
    import cv2

    img = image.astype(np.float32)
    have = coverage.astype(np.float32)
    kernel = np.ones((3, 3), np.float32)
    for _ in range(iterations):
        summed = cv2.filter2D(img * have[..., None], -1, kernel, borderType=cv2.BORDER_CONSTANT)
        count = cv2.filter2D(have, -1, kernel, borderType=cv2.BORDER_CONSTANT)
        if summed.ndim == 2:
            summed = summed[..., None]
        grow = (have == 0) & (count > 0)
        img[grow] = summed[grow] / count[grow][:, None]
        have = np.maximum(have, grow.astype(np.float32))
    return img.astype(image.dtype) if image.dtype != np.uint8 else np.clip(np.rint(img), 0, 255).astype(np.uint8)
