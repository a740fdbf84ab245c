"""The page's lighter mesh (morf/web/light_mesh.py): fewer triangles over original vertices, the
texture seams and the surface closed as before, the head and hands kept densest, its error bound
held, and its frames close to the full mesh's."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest


@pytest.fixture(scope="module")
def full_and_light(tiny_avatar):
    """The tiny avatar and its first level (4 mm) as the web folder makes it."""
    from morf.export.avatar_folder import load_exported_avatar
    from morf.web.light_mesh import light_meshes

    avatar = load_exported_avatar(tiny_avatar)
    return avatar, light_meshes(avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents)[0]


def _edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0, return_counts=True)


def _welded(mesh, faces):
    """Faces over vertices merged by position (the split copies of a seam become one)."""
    _, inverse = np.unique(np.round(mesh.rest_vertices, 6), axis=0, return_inverse=True)
    return inverse.reshape(-1)[faces]


def test_fewer_triangles_over_the_original_vertices(full_and_light):
    avatar, light = full_and_light
    full, m = avatar.mesh, light.mesh
    f, fl = full.faces.shape[0], m.faces.shape[0]
    assert 0.4 * f <= fl <= 0.7 * f, light.describe()
    assert light.faces_before == f and 0 < light.max_error_m <= 4e-3
    for field in ("rest_vertices", "uvs", "bone_indices", "bone_weights"):
        assert np.array_equal(getattr(m, field), getattr(full, field)[light.kept]), field
    assert np.array_equal(np.unique(m.faces), np.arange(len(light.kept)))  # compact: every vertex used
    assert (m.faces[:, 0] != m.faces[:, 1]).all() and (m.faces[:, 1] != m.faces[:, 2]).all()


def test_seams_and_the_closed_surface_are_kept(full_and_light):
    """Every seam edge is still there with both its sides (no crack opens in the image), the welded
    surface has the same open edges as before, and no face folds over in the atlas."""
    avatar, light = full_and_light
    full = avatar.mesh
    faces = light.kept[light.mesh.faces]  # the full mesh's vertex numbers
    e_full, n_full = _edges(full.faces)
    e_light, n_light = _edges(faces)
    seam_full = {tuple(e) for e in e_full[n_full == 1]}
    assert seam_full == {tuple(e) for e in e_light[n_light == 1]}
    w_full, nw_full = _edges(_welded(full, full.faces))
    w_light, nw_light = _edges(_welded(full, faces))
    assert {tuple(e) for e in w_full[nw_full == 1]} == {tuple(e) for e in w_light[nw_light == 1]}
    assert nw_light.max() <= 2

    def winding(mesh_uvs, f):
        t = mesh_uvs[f]
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        return np.sign(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])

    assert set(np.unique(winding(full.uvs, faces))) <= set(np.unique(winding(full.uvs, full.faces)))
    assert (winding(full.uvs, faces) != 0).all()


def test_head_and_hands_cost_more(full_and_light):
    """Their weight keeps more of the head's and the hands' triangles than a plain decimation does."""
    from morf.web.light_mesh import detail_share, light_mesh

    avatar, light = full_and_light
    share = detail_share(avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents)
    assert share.max() == pytest.approx(1.0) and share.min() == 0.0
    on_detail = lambda faces: (share[faces] > 0.5).all(axis=1)  # noqa: E731
    full = on_detail(avatar.mesh.faces).sum()
    plain = light_mesh(avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents, detail_weight=0.0)
    kept = on_detail(light.kept[light.mesh.faces]).sum() / full
    kept_plain = on_detail(plain.kept[plain.mesh.faces]).sum() / full
    assert full > 1000 and kept > kept_plain + 0.05, (kept, kept_plain)


def test_the_error_bound_and_the_floor_hold(full_and_light):
    from morf.web.light_mesh import light_mesh

    avatar, _ = full_and_light
    args = (avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents)
    assert light_mesh(*args, max_error_m=1e-9).mesh.faces.shape[0] == avatar.mesh.faces.shape[0]
    assert light_mesh(*args, keep=1.0).mesh.faces.shape[0] == avatar.mesh.faces.shape[0]
    tighter = light_mesh(*args, max_error_m=1e-3)
    assert avatar.mesh.faces.shape[0] > tighter.mesh.faces.shape[0] > full_and_light[1].mesh.faces.shape[0]
    floor = light_mesh(*args, keep=0.8, max_error_m=1.0)  # the floor stops it first
    assert floor.mesh.faces.shape[0] <= int(np.ceil(0.8 * avatar.mesh.faces.shape[0])) + 2
    with pytest.raises(ValueError, match="keep"):
        light_mesh(*args, keep=0.0)


def test_levels_go_on_from_each_other(full_and_light):
    """The web folder's levels (4 and 8 mm): the second is the first decimated further, and the
    folder carries both with their error bounds."""
    from morf.web.light_mesh import LEVELS_M, light_mesh, light_meshes

    avatar, _ = full_and_light
    first, second = light_meshes(avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents)  # remembered
    assert LEVELS_M == (4e-3, 8e-3)
    # the first level is the 4 mm decimation on its own
    assert np.array_equal(first.kept, light_mesh(avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents).kept)
    assert second.mesh.faces.shape[0] < 0.9 * first.mesh.faces.shape[0]
    assert set(second.kept) <= set(first.kept) and first.max_error_m <= second.max_error_m <= 8e-3
    with pytest.raises(ValueError, match="rising"):
        light_meshes(avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents, bounds_m=(8e-3, 4e-3))


@pytest.mark.gl
def test_frames_of_the_light_mesh_are_close_to_the_full_meshs(full_and_light):
    """The Python player with either mesh: the tiny avatar's steep sinusoid texture is the hard case
    (29.9-34.4 dB measured at 256 px; the trained demo avatar 37.5-40.4 dB at 640 px)."""
    from morf.playback.player import Player
    from morf.raster.camera_paths import front_camera
    from morf.web.check import psnr

    avatar, light = full_and_light
    rng = np.random.default_rng(3)
    frames = []
    for k in range(2):
        rot = (rng.normal(size=(avatar.skeleton.num_bones, 3)) * 0.08).astype(np.float32)
        rot[0] = (0.0, 0.0, 0.8 * k)
        frames.append((rot, np.zeros(3, np.float32), front_camera(256, yaw_deg=45.0 * k)))
    images = []
    for a in (avatar, dataclasses.replace(avatar, mesh=light.mesh)):
        with Player(a, size=256) as p:
            images.append([p.render(*f) for f in frames])
            if a is avatar:
                body = [p.rasterize(*f).reshape(256, 256, 16)[..., 0] != 128 for f in frames]
    for x, y, m in zip(*images, body):
        assert m.sum() > 2000 and psnr(x, y, m) >= 28.0, psnr(x, y, m)
