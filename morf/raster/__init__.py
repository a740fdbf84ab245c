"""Rasterization: posed render meshes to per-pixel UVs (training input) and textured frames.

OpenGL through a headless EGL context (``gl_*`` modules, one context per thread);
``soft_silhouette`` is the differentiable silhouette used by fitting; ``neural_raster`` (GPU
skinning + uint8 neural texture lookup) and ``texture_quant`` (that texture's quantisation) are
what export and playback draw an avatar with.

Names are loaded on first use so that torch-free code (the exported-avatar player) can import
``morf.raster.neural_raster`` without pulling in torch through the other modules.
"""

from morf.lazy import lazy_attributes

_WHERE = {
    "bake_vertex_attributes": "gl_atlas", "dilate_charts": "gl_atlas",
    "GLUnavailable": "gl_context", "adopt_gl_context": "gl_context", "create_headless_context": "gl_context",
    "gl_context": "gl_context",
    "gl_state": "gl_context", "release_gl_context": "gl_context",
    "Rasterization": "gl_mesh", "rasterize_uv": "gl_mesh", "rasterize_uv_batch": "gl_mesh",
    "GLTexture": "gl_textured", "render_mesh_normals": "gl_textured", "render_textured": "gl_textured",
    "upload_texture": "gl_textured",
}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_attributes(__name__, {name: f"morf.raster.{module}" for name, module in _WHERE.items()})
