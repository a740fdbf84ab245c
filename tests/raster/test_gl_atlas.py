"""Baking vertex attributes into the UV atlas, and growing charts into the empty atlas."""

import numpy as np
import pytest

from morf.body.render_mesh import RenderMesh
from morf.raster import bake_vertex_attributes, dilate_charts

pytestmark = pytest.mark.gl


def test_bake_interpolates_at_texel_centres(gl):
    # a triangle covering the lower-left half of the atlas (u + v < 1), attribute = (u, v, 2u, 5)
    uvs = np.array([[0, 0], [1, 0], [0, 1]], np.float32)
    mesh = RenderMesh(np.arange(3), uvs, np.array([[0, 1, 2]], np.int32), np.zeros((3, 1), np.int32),
                      np.ones((3, 1), np.float32))
    attrs = np.concatenate([uvs, 2 * uvs[:, :1], np.full((3, 1), 5.0), uvs[:, 1:] * 3], 1)  # 5 channels
    S = 16
    vals, cover = bake_vertex_attributes(mesh, attrs, S)
    assert vals.shape == (S, S, 5) and cover.shape == (S, S)
    rows, cols = np.mgrid[0:S, 0:S]
    u, v = (cols + 0.5) / S, 1 - (rows + 0.5) / S  # texture row 0 is v = 1
    inside = u + v < 1 - 1e-3
    outside = u + v > 1 + 1e-3
    assert cover[inside].all() and not cover[outside].any()
    np.testing.assert_allclose(vals[inside][:, 0], u[inside], atol=1e-5)
    np.testing.assert_allclose(vals[inside][:, 1], v[inside], atol=1e-5)
    np.testing.assert_allclose(vals[inside][:, 2], 2 * u[inside], atol=1e-5)
    np.testing.assert_allclose(vals[inside][:, 3], 5.0)
    np.testing.assert_allclose(vals[inside][:, 4], 3 * v[inside], atol=1e-5)


def test_dilate_grows_charts_without_touching_them():
    img = np.zeros((10, 10, 3), np.uint8)
    cover = np.zeros((10, 10), bool)
    img[4:6, 4:6] = (200, 100, 50)
    cover[4:6, 4:6] = True
    out = dilate_charts(img, cover, iterations=2)
    assert np.array_equal(out[4:6, 4:6], img[4:6, 4:6])
    assert tuple(out[2, 4]) == (200, 100, 50) and tuple(out[0, 0]) == (0, 0, 0)
