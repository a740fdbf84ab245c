"""OpenGL silhouettes against the per-pixel test in torch, and the fallback without GL."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from morf.body.model import BodyPose
from morf.camera import PinholeCamera
from morf.raster.soft_silhouette import hard_coverage


def _posed(body_model, n=3):
    pose = body_model.zero_pose(n)
    rot = pose.rotvecs.clone()
    rot[:, 0, 2] = torch.tensor([0.0, 1.2, 2.6])[:n]  # turned about the vertical axis
    with torch.no_grad():
        return body_model(BodyPose(rot, pose.transl), body_model.default_shape()).vertices


def _torch_silhouettes(vertices, faces, camera, scale, w, h):
    tri = (camera.project(vertices) * scale)[:, faces]
    in_front = (camera.world_to_camera(vertices)[..., 2] > 1e-3)[:, faces].all(-1)
    return hard_coverage(tri, in_front, h, w).numpy()


@pytest.mark.parametrize("scale,size", [(1.0, 160), (0.5, 80)])
def test_gl_silhouettes_cover_the_same_pixel_centres(body_model, gl, scale, size):
    from morf.raster.gl_silhouette import silhouettes_gl

    cam = PinholeCamera.look_at(160, 160, 40.0, eye=(0.0, -3.4, 0.2), target=(0.0, 0.0, -0.1))
    verts = _posed(body_model)
    ref = _torch_silhouettes(verts, body_model.faces, cam, scale, size, size)
    out = silhouettes_gl(verts, body_model.faces, cam, scale, size, size)
    assert out.shape == ref.shape == (3, size, size) and out.dtype == bool
    area = ref.sum((1, 2))
    assert (area > 0.05 * size * size).all()
    # only pixel centres lying on a triangle edge may differ
    assert ((out != ref).sum((1, 2)) <= np.maximum(3, 0.002 * area)).all()


def test_without_gl_the_fit_evaluation_draws_them_in_torch(body_model, monkeypatch):
    import morf.raster.gl_silhouette as gs
    from morf.fitting.evaluate import silhouettes
    from morf.raster.gl_context import GLUnavailable
    from morf.raster.soft_silhouette import front_facing

    def no_gl(*a, **k):
        raise GLUnavailable("no EGL here")

    monkeypatch.setattr(gs, "silhouettes_gl", no_gl)
    cam = PinholeCamera.look_at(64, 64, 40.0, eye=(0.0, -3.4, 0.2), target=(0.0, 0.0, -0.1))
    verts = _posed(body_model, 1)
    out = silhouettes(verts, body_model.faces, cam, 1.0, 64, 64)
    np.testing.assert_array_equal(out, _torch_silhouettes(verts, body_model.faces, cam, 1.0, 64, 64))
    # front_only keeps the camera-facing triangles there too (an open mesh shows the difference)
    faces = body_model.faces[::3]
    cam_v = cam.world_to_camera(verts)
    keep = (cam_v[..., 2] > 1e-3)[:, faces].all(-1) & front_facing(cam_v, faces)
    ref = hard_coverage(cam.project(verts)[:, faces], keep, 64, 64).numpy()
    np.testing.assert_array_equal(silhouettes(verts, faces, cam, 1.0, 64, 64, front_only=True), ref)
    assert (silhouettes(verts, faces, cam, 1.0, 64, 64) != ref).any()


def test_front_only_draws_the_triangles_facing_the_camera(body_model, gl):
    from morf.fitting.evaluate import silhouettes
    from morf.raster.soft_silhouette import front_facing

    cam = PinholeCamera.look_at(120, 120, 40.0, eye=(0.0, -3.4, 0.2), target=(0.0, 0.0, -0.1))
    verts = _posed(body_model, 2)
    faces = body_model.faces[::3]  # an open mesh: back faces show through the gaps
    cam_v = cam.world_to_camera(verts)
    keep = (cam_v[..., 2] > 1e-3)[:, faces].all(-1) & front_facing(cam_v, faces)
    ref = hard_coverage((cam.project(verts))[:, faces], keep, 120, 120).numpy()
    out = silhouettes(verts, faces, cam, 1.0, 120, 120, front_only=True)
    every = silhouettes(verts, faces, cam, 1.0, 120, 120)
    assert ((out != ref).sum((1, 2)) <= np.maximum(3, 0.002 * ref.sum((1, 2)))).all()
    assert ((every != ref).sum((1, 2)) > 50).all()  # the back faces do change this mesh's picture



def test_a_failed_egl_context_is_not_tried_again(monkeypatch):
    import threading

    import morf.raster.gl_context as glc

    calls = []

    def failing():
        calls.append(1)
        raise glc.GLUnavailable("no EGL here")

    monkeypatch.setattr(glc, "create_headless_context", failing)
    monkeypatch.setattr(glc, "_EGL_FAILURE", [])
    errors = []

    def on_a_fresh_thread():  # a thread without a context yet
        for _ in range(3):
            try:
                glc.gl_state()
            except glc.GLUnavailable as e:
                errors.append(str(e))

    t = threading.Thread(target=on_a_fresh_thread)
    t.start()
    t.join()
    assert calls == [1] and errors == ["no EGL here"] * 3
