"""Rasterization: posed render meshes to per-pixel UVs (training input) and textured frames.

OpenGL through a headless EGL context (``gl_*`` modules, one context per thread);
``soft_silhouette`` is the differentiable silhouette used by fitting.
"""

from morf.raster.gl_atlas import bake_vertex_attributes, dilate_charts
from morf.raster.gl_context import GLUnavailable, adopt_gl_context, gl_context, gl_state, release_gl_context
from morf.raster.gl_mesh import Rasterization, rasterize_uv, rasterize_uv_batch
from morf.raster.gl_textured import GLTexture, render_mesh_normals, render_textured, upload_texture

__all__ = [
    "GLTexture",
    "GLUnavailable",
    "Rasterization",
    "adopt_gl_context",
    "bake_vertex_attributes",
    "dilate_charts",
    "gl_context",
    "gl_state",
    "rasterize_uv",
    "rasterize_uv_batch",
    "release_gl_context",
    "render_mesh_normals",
    "render_textured",
    "upload_texture",
]
