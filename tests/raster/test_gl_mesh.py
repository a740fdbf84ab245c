"""UV rasterization lands exactly where PinholeCamera.project says, with exact interpolation."""

import threading

import numpy as np
import pytest
import torch

from morf.body.render_mesh import RenderMesh
from morf.camera import PinholeCamera
from morf.raster import rasterize_uv, rasterize_uv_batch

pytestmark = pytest.mark.gl


def _mesh(uvs, faces) -> RenderMesh:
    n = len(uvs)
    return RenderMesh(vertex_map=np.arange(n), uvs=np.asarray(uvs, np.float32), faces=np.asarray(faces, np.int32),
                      bone_indices=np.zeros((n, 1), np.int32), bone_weights=np.ones((n, 1), np.float32))


def _camera(W=40, H=30):
    # An off-centre, rotated camera so that no axis-aligned coincidence hides a convention error.
    cam = PinholeCamera.look_at(W, H, 50.0, eye=(0.3, -2.0, 0.4), target=(0.05, 0.0, 0.1))
    return PinholeCamera(cam.fx, cam.fy * 1.1, cam.cx + 1.3, cam.cy - 0.7, W, H, cam.R, cam.t)


def _pixel_rays(cam):
    """Pixel-centre rays in world space: origin (3,), directions (H, W, 3)."""
    ys, xs = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    d_cam = np.stack([(xs - cam.cx) / cam.fx, (ys - cam.cy) / cam.fy, np.ones_like(xs)], -1)
    return cam.position, d_cam @ cam.R  # R^T d for row vectors


def _ray_triangle(origin, dirs, a, b, c):
    """Per pixel: hit flag, barycentrics (H, W, 3), camera depth along the ray param."""
    e1, e2 = b - a, c - a
    n = np.cross(e1, e2)
    t = ((a - origin) @ n) / (dirs @ n)
    p = origin + t[..., None] * dirs
    # barycentrics by areas in 3D
    def area(x, y, z):
        return np.cross(y - x, z - x) @ n
    tot = area(a, b, c)
    w0, w1, w2 = area(p, b, c) / tot, area(a, p, c) / tot, area(a, b, p) / tot
    bary = np.stack([w0, w1, w2], -1)
    return bary.min(-1), bary, p


def test_triangle_covers_exactly_the_projected_pixels(gl):
    cam = _camera()
    verts = np.array([[-0.35, -0.1, -0.3], [0.45, 0.05, -0.2], [0.02, 0.1, 0.55]])
    mesh = _mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    r = rasterize_uv(verts, mesh, cam)
    origin, dirs = _pixel_rays(cam)
    inside_margin, bary, p = _ray_triangle(origin, dirs, *verts)
    clear = np.abs(inside_margin) > 1e-3  # skip pixel centres on an edge (GL tie rules)
    assert clear.sum() > 0.9 * cam.width * cam.height
    assert np.array_equal(r.mask[clear], (inside_margin > 0)[clear])
    assert 30 < r.mask.sum() < cam.width * cam.height - 30  # a real triangle, not everything or nothing
    # the projected corners fall in the covered region's bounding box
    px = cam.project(torch.as_tensor(verts)).numpy()
    ys, xs = np.nonzero(r.mask)
    assert xs.min() + 0.5 >= px[:, 0].min() - 1e-6 and xs.max() + 0.5 <= px[:, 0].max() + 1e-6
    assert ys.min() + 0.5 >= px[:, 1].min() - 1e-6 and ys.max() + 0.5 <= px[:, 1].max() + 1e-6


def test_uv_and_depth_are_perspective_correct_at_pixel_centres(gl):
    cam = _camera(48, 36)
    verts = np.array([[-0.5, -0.4, -0.4], [0.5, 0.3, -0.35], [0.5, 0.35, 0.5], [-0.45, -0.3, 0.45]])
    uvs = np.array([[0.1, 0.2], [0.9, 0.25], [0.85, 0.95], [0.05, 0.8]])
    mesh = _mesh(uvs, [[0, 1, 2], [0, 2, 3]])
    r = rasterize_uv(torch.as_tensor(verts, dtype=torch.float32), mesh, cam)
    origin, dirs = _pixel_rays(cam)
    for f, (i, j, k) in enumerate(mesh.faces):
        inside, bary, p = _ray_triangle(origin, dirs, verts[i], verts[j], verts[k])
        sel = (inside > 1e-3) & r.mask
        assert sel.sum() > 50
        assert np.all(r.face_id[sel] == f)
        uv_ref = bary @ uvs[[i, j, k]]
        np.testing.assert_allclose(r.uv[sel], uv_ref[sel], atol=2e-4)
        z_ref = (p @ cam.R.T + cam.t)[..., 2]
        np.testing.assert_allclose(r.depth[sel], z_ref[sel], rtol=1e-4)
    assert np.all(r.face_id[~r.mask] == -1) and np.all(r.depth[~r.mask] == 0)


def test_nearer_surface_wins(gl):
    cam = PinholeCamera.look_at(32, 32, 40.0, eye=(0, -3, 0), target=(0, 0, 0))
    back = [[-1, 0.5, -1], [1, 0.5, -1], [0, 0.5, 1]]
    front = [[-1, -0.5, -1], [1, -0.5, -1], [0, -0.5, 1]]
    mesh = _mesh([[0, 0]] * 3 + [[1, 1]] * 3, [[0, 1, 2], [3, 4, 5]])
    for order in (back + front, front + back):
        r = rasterize_uv(np.array(order, float), mesh, cam)
        front_face = 1 if order[0] == back[0] else 0
        centre = r.face_id[16, 16]
        assert centre == front_face


def test_batch_matches_single_frames_and_threads_get_their_own_context(gl):
    cam = _camera()
    mesh = _mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    frames = np.array([[[-0.3, 0, -0.3], [0.4, 0, -0.2], [0, 0, 0.5]],
                       [[-0.1, 0, -0.4], [0.5, 0.1, 0.1], [-0.2, 0, 0.4]]])
    batch = rasterize_uv_batch(frames, mesh, cam)
    assert batch.uv.shape == (2, cam.height, cam.width, 2) and batch.mask.shape == (2, cam.height, cam.width)
    for b in range(2):
        single = rasterize_uv(frames[b], mesh, cam)
        assert np.array_equal(single.mask, batch.mask[b]) and np.array_equal(single.uv, batch.uv[b])
    result = {}

    def worker():
        from morf.raster import release_gl_context

        result["mask"] = rasterize_uv(frames[0], mesh, cam).mask
        release_gl_context()

    t = threading.Thread(target=worker)
    t.start()
    t.join()
    assert np.array_equal(result["mask"], batch.mask[0])


def test_bad_vertices_give_a_clear_error(gl):
    from morf.errors import InputError

    mesh = _mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    with pytest.raises(InputError, match="render-mesh vertices"):
        rasterize_uv(np.zeros((4, 3)), mesh, _camera())


def test_other_contexts_on_the_same_thread_do_not_disturb(gl):
    import moderngl

    cam = _camera()
    mesh = _mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    tri = np.array([[-0.3, 0, -0.3], [0.4, 0, -0.2], [0, 0, 0.5]])
    before = rasterize_uv(tri, mesh, cam)
    other = moderngl.create_standalone_context(backend="egl")  # becomes current on this thread
    other_fbo = other.simple_framebuffer((8, 8))
    after = rasterize_uv(tri, mesh, cam)
    other_fbo.use()  # the other context is current again after our call
    other_fbo.clear(1.0, 0.0, 0.0, 1.0)
    assert other_fbo.read()[:3] == b"\xff\x00\x00"
    other.release()
    again = rasterize_uv(tri, mesh, cam)
    assert np.array_equal(before.uv, after.uv) and np.array_equal(before.uv, again.uv) and before.mask.any()
