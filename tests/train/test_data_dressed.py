"""The dressed body: clothing offsets move the rest vertices outward along the rest normals, and
that surface is what training rasterizes and what the avatar folder's mesh.npz stores."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from morf.body.render_mesh import render_mesh_for
from morf.export.export_avatar import clothing_entry, skinned_mesh_from_body_model
from morf.fitting.offsets import dressed_rest_vertices, rest_normals
from morf.train.data import build_frames, clothing_offsets, load_body_fits, posed_render_vertices
from tests.train.dressed_fits import height_offsets, write_dressed_fits


@pytest.fixture(scope="module")
def offsets(body_model):
    return height_offsets(body_model)


def _rest_and_normals(body_model, shape):
    rm = render_mesh_for(body_model)
    with torch.no_grad():
        rest = body_model.rest(shape)["rest_vertices"][0].numpy()[rm.vertex_map]
    return rest, rest_normals(body_model, shape)[0].numpy()[rm.vertex_map], rm.vertex_map


def test_dressed_rest_vertices_move_out_along_the_normals_by_exactly_the_offsets(body_model, offsets):
    shape = body_model.default_shape()
    rest, normals, vmap = _rest_and_normals(body_model, shape)
    stored = skinned_mesh_from_body_model(body_model, shape, offsets).rest_vertices  # the avatar folder's mesh
    d = stored.astype(np.float64) - rest
    along = (d * normals).sum(1)
    np.testing.assert_allclose(along, offsets[vmap], atol=2e-6)  # outward, by the offset
    np.testing.assert_allclose(np.linalg.norm(d - along[:, None] * normals, axis=1), 0, atol=2e-6)  # nothing else
    naked = skinned_mesh_from_body_model(body_model, shape).rest_vertices
    np.testing.assert_allclose(naked, rest, atol=1e-6)
    np.testing.assert_allclose(dressed_rest_vertices(body_model, shape, None)[0].numpy()[vmap], rest, atol=1e-6)


def test_posed_training_vertices_are_the_dressed_rest_vertices_skinned(body_model, offsets, still_pose):
    """What training rasterizes is the stored dressed rest mesh skinned by the body's bones; the
    offset stays a displacement of at most its length (the blended rotation of the normal)."""
    from morf.body import BodyPose
    from morf.body.lbs import linear_blend_skinning

    shape = body_model.default_shape()
    rot, tr = still_pose
    trained_on = posed_render_vertices(body_model, rot[None], tr[None], shape.numpy(), offsets)[0]
    with torch.no_grad():
        out = body_model(BodyPose(torch.from_numpy(rot[None]), torch.from_numpy(tr[None])), shape)
        skinned = linear_blend_skinning(dressed_rest_vertices(body_model, shape, offsets).float(),
                                        body_model.dense_weights.float(), out.bone_transforms.float())[0].numpy()
    vmap = render_mesh_for(body_model).vertex_map
    np.testing.assert_allclose(trained_on, skinned[vmap], atol=2e-5)
    naked = posed_render_vertices(body_model, rot[None], tr[None], shape.numpy())[0]
    moved = np.linalg.norm(trained_on - naked, axis=1)
    assert (moved <= offsets[vmap] + 1e-5).all() and np.median(moved / offsets[vmap]) > 0.99


def test_training_frames_are_rasterized_from_the_dressed_body(tiny_capture, body_model, offsets):
    write_dressed_fits(tiny_capture, body_model, offsets)
    fits = load_body_fits(tiny_capture)
    np.testing.assert_array_equal(clothing_offsets(fits), offsets)
    assert clothing_offsets(fits, dressed=False) is None
    dressed = build_frames(tiny_capture, body_model, 64)
    naked = build_frames(tiny_capture, body_model, 64, dressed=False)
    assert dressed.cache_path != naked.cache_path  # the offsets are part of the cache key
    np.testing.assert_array_equal(dressed.offsets, offsets)
    assert naked.offsets is None
    a, b = dressed.frames.uv_mask, naked.frames.uv_mask
    assert (a & ~b).sum() > 0.05 * b.sum()  # 1-5 cm all round: the dressed body covers more
    assert (b & ~a).sum() < 0.002 * b.sum()  # and holds the naked one
    again = build_frames(tiny_capture, body_model, 64)  # from the cache, still dressed
    np.testing.assert_array_equal(again.frames.uv_mask, a)
    np.testing.assert_array_equal(again.offsets, offsets)


def test_manifest_entry_names_the_dressing(offsets):
    e = clothing_entry(offsets)
    assert e["dressed"] and e["offset_mean_mm"] == pytest.approx(1000 * offsets.mean(), abs=0.01)
    assert e["offset_max_mm"] == pytest.approx(50.0, abs=0.01)
    assert clothing_entry(None)["dressed"] is False
