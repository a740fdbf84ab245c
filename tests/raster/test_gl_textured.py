"""Textured rendering: colours from the right texels, coverage, determinism, shading."""

import numpy as np
import pytest

from morf.body.render_mesh import RenderMesh
from morf.camera import PinholeCamera
from morf.raster import rasterize_uv, render_mesh_normals, render_textured, upload_texture

pytestmark = pytest.mark.gl


def _quad():
    # A square in the plane y = 0 facing a camera on -Y; v up = world z up.
    verts = np.array([[-0.5, 0, -0.5], [0.5, 0, -0.5], [0.5, 0, 0.5], [-0.5, 0, 0.5]], np.float32)
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    mesh = RenderMesh(vertex_map=np.arange(4), uvs=uvs, faces=np.array([[0, 1, 2], [0, 2, 3]], np.int32),
                      bone_indices=np.zeros((4, 1), np.int32), bone_weights=np.ones((4, 1), np.float32))
    return verts, mesh


def _texture():
    # Top half (v > 0.5) red, bottom-left green, bottom-right blue.
    tex = np.zeros((64, 64, 3), np.uint8)
    tex[:32] = (255, 0, 0)
    tex[32:, :32] = (0, 255, 0)
    tex[32:, 32:] = (0, 0, 255)
    return tex


def test_texture_orientation_and_background(gl):
    verts, mesh = _quad()
    cam = PinholeCamera.look_at(64, 64, 40.0, eye=(0, -3, 0), target=(0, 0, 0))
    rgb, mask = render_textured(verts, mesh, cam, _texture(), background=(10, 20, 30), msaa=4)
    assert tuple(rgb[0, 0]) == (10, 20, 30) and not mask[0, 0]
    assert tuple(rgb[26, 32]) == (255, 0, 0)  # above the centre: world z up, v up, texture top
    assert tuple(rgb[38, 26]) == (0, 255, 0)  # below left: u small
    assert tuple(rgb[38, 38]) == (0, 0, 255)


def test_mask_matches_uv_rasterization_and_render_is_deterministic(gl):
    verts, mesh = _quad()
    verts = verts @ np.array([[0.9, 0.3, 0.1], [-0.3, 0.9, 0.2], [0.0, -0.2, 0.95]], np.float32)
    cam = PinholeCamera.look_at(96, 80, 45.0, eye=(0.2, -2.5, 0.3), target=(0, 0, 0))
    tex = upload_texture(_texture())
    a = render_textured(verts, mesh, cam, tex, msaa=4, shading=1.0)
    b = render_textured(verts, mesh, cam, tex, msaa=4, shading=1.0)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    exact = rasterize_uv(verts, mesh, cam).mask
    inter, union = (a[1] & exact).sum(), (a[1] | exact).sum()
    assert inter / union > 0.97
    # every disagreement is on the silhouette border
    diff = np.argwhere(a[1] != exact)
    for y, x in diff:
        window = exact[max(0, y - 1):y + 2, max(0, x - 1):x + 2]
        assert window.any() and not window.all()
    tex.release()


def test_uv_override_and_shading(gl):
    verts, mesh = _quad()
    cam = PinholeCamera.look_at(48, 48, 40.0, eye=(0, -3, 0), target=(0, 0, 0))
    shifted = mesh.uvs * 0.2 + np.array([0.7, 0.05], np.float32)  # only the blue corner
    rgb, _ = render_textured(verts, mesh, cam, _texture(), uvs=shifted)
    assert tuple(rgb[24, 24]) == (0, 0, 255)
    # the override is per call: the next render uses the mesh's own UVs again
    rgb2, _ = render_textured(verts, mesh, cam, _texture())
    assert tuple(rgb2[18, 24]) == (255, 0, 0)
    # a light from behind the quad darkens it; flat shading keeps the albedo
    dark, _ = render_textured(verts, mesh, cam, _texture(), shading=1.0, light_dir_cam=(0, 0, 1))
    assert dark[18, 24, 0] < 120


def test_normals_point_out_of_a_closed_surface():
    # a tetrahedron: every vertex normal points away from the centroid
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int32)
    mesh = RenderMesh(np.arange(4), np.zeros((4, 2), np.float32), faces, np.zeros((4, 1), np.int32),
                      np.ones((4, 1), np.float32))
    n = render_mesh_normals(v, mesh)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1, atol=1e-6)
    assert np.all(((v - v.mean(0)) * n).sum(1) > 0)
