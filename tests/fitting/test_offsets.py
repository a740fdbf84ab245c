"""Clothing offsets: normals, skinning of offsets, spreading to the full mesh, storage, and a fit
against masks of a body fatter than the model."""

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.fitting import fit_sequence, finalize, preset
from morf.fitting.fit_body import FitBody
from morf.fitting.fits_io import BodyFits, read_fits, save_fits
from morf.fitting.inputs import FitInputs, downsample_mask, raster_size
from morf.fitting.offsets import (dressed_vertices, proxy_edges, rest_normals, smoothness_loss, spread_to_mesh,
                                  spread_weights, vertex_normals_torch)
from morf.fitting.proxy_mesh import body_proxy

from .synthetic import make_inputs, turning_poses

SHAPE = torch.tensor([[0.55, 0.45, 0.5, 0.55, 0.5, 0.5]])


def _pose(n=2, seed=0):
    g = torch.Generator().manual_seed(seed)
    return BodyPose(0.2 * torch.randn(n, 104, 3, generator=g), 0.1 * torch.randn(n, 3, generator=g))


def test_vertex_normals_point_outwards_on_a_tetrahedron():
    v = torch.tensor([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]])
    f = torch.tensor([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    n = vertex_normals_torch(v, f)[0]
    centre = v[0].mean(0)
    assert torch.allclose(n.norm(dim=-1), torch.ones(4))
    assert ((n * (v[0] - centre)).sum(-1) > 0).all()


def test_rest_normals_are_remembered_per_shape(body_model):
    with torch.no_grad():
        fresh = lambda shape: vertex_normals_torch(body_model.rest(shape)["rest_vertices"], body_model.faces)  # noqa: E731
    a = rest_normals(body_model, SHAPE)
    assert rest_normals(body_model, SHAPE.clone()) is a  # the same shape by value: remembered
    other = SHAPE + 0.1
    b = rest_normals(body_model, other)
    assert torch.equal(a, fresh(SHAPE)) and torch.equal(b, fresh(other)) and not torch.equal(a, b)
    for k in range(5):  # a few shapes later the first is computed again, equal
        rest_normals(body_model, SHAPE + 0.01 * (k + 1))
    again = rest_normals(body_model, SHAPE)
    assert again is not a and torch.equal(again, a)


def test_body_normals_point_outwards(body_model):
    n = rest_normals(body_model, SHAPE)[0]
    rest = body_model.rest(SHAPE)["rest_vertices"][0]
    # pushing the surface out along its normals grows the body's horizontal cross-section
    out = rest + 0.01 * n
    assert (out[:, :2] - rest[:, :2].mean(0)).norm(dim=-1).mean() > (rest[:, :2] - rest[:, :2].mean(0)).norm(dim=-1).mean()


def test_offsets_are_skinned_like_the_rest_mesh(body_model):
    pose = _pose()
    offsets = torch.rand(body_model.dense_weights.shape[0]) * 0.03
    out = body_model(pose, SHAPE)
    dressed = dressed_vertices(body_model, out, SHAPE, offsets)
    # reference: skin the offset rest mesh with the model's own skinning matrices
    rest = body_model.rest(SHAPE)["rest_vertices"][0] + offsets[:, None] * rest_normals(body_model, SHAPE)[0]
    blend = torch.einsum("vj,bjcd->bvcd", body_model.dense_weights, out.bone_transforms)
    ref = (blend[..., :3, :3] @ rest[None, :, :, None]).squeeze(-1) + blend[..., :3, 3]
    assert torch.allclose(dressed, ref, atol=1e-5)
    assert dressed_vertices(body_model, out, SHAPE, None) is out.vertices


def test_fit_body_applies_proxy_offsets(body_model):
    proxy = body_proxy(body_model, 0.03)
    fb = FitBody(body_model, proxy)
    pose = _pose()
    full = torch.rand(body_model.dense_weights.shape[0]) * 0.03
    off = full[fb.proxy_ids]
    got = fb(pose, SHAPE, proxy_offsets=off).proxy_vertices
    ref = dressed_vertices(body_model, body_model(pose, SHAPE), SHAPE, full)[:, fb.proxy_ids]
    assert torch.allclose(got, ref, atol=1e-4)


def test_spread_keeps_proxy_values_and_smoothness_is_zero_for_constants(body_model):
    proxy = body_proxy(body_model, 0.03)
    ids = torch.as_tensor(proxy.vertex_ids)
    rest = body_model.rest(body_model.default_shape())["rest_vertices"][0]
    nn, w = spread_weights(rest, ids)
    assert torch.allclose(w.sum(1), torch.ones(len(rest)))
    values = torch.linspace(0.0, 0.05, len(ids))
    full = spread_to_mesh(body_model, proxy.vertex_ids, values)
    assert torch.allclose(full[ids], values, atol=1e-6)
    assert full.min() >= 0 and full.max() <= 0.05 + 1e-6
    edges = proxy_edges(proxy.faces)
    assert smoothness_loss(torch.full((len(ids),), 0.02), edges) == 0
    assert smoothness_loss(values, edges) > 0


def test_fits_round_trip_with_and_without_offsets(tmp_path):
    N, V = 3, 10
    base = dict(rotvecs=np.zeros((N, 104, 3), np.float32), transl=np.zeros((N, 3), np.float32),
                shape=np.full((1, 6), 0.5, np.float32), keypoint_residual_px=np.ones(N, np.float32),
                keypoint_worst_px=np.ones(N, np.float32), silhouette_iou=np.full(N, 0.9, np.float32),
                projected_keypoints=np.zeros((N, 23, 2), np.float32), config={"a": 1})
    save_fits(tmp_path / "a.npz", BodyFits(**base))
    a = read_fits(tmp_path / "a.npz")
    assert a.offsets is None and a.silhouette_iou_body is None
    off = np.linspace(0, 0.02, V).astype(np.float32)
    save_fits(tmp_path / "b.npz", BodyFits(**base, silhouette_iou_body=np.full(N, 0.8, np.float32), offsets=off))
    b = read_fits(tmp_path / "b.npz")
    np.testing.assert_allclose(b.offsets, off)
    np.testing.assert_allclose(b.silhouette_iou_body, 0.8)


def test_offsets_grow_towards_masks_of_a_dressed_body(body_model):
    """Masks of the body pushed 2.5 cm outwards: the fit's offsets grow and its surface matches
    the masks better than the body alone, while the body stays close to the truth."""
    n, size = 4, 256
    pose = turning_poses(body_model, n, turn=np.pi / 2, cycles=0.25)
    inputs, gt = make_inputs(body_model, pose, SHAPE, size=size, sil_res=128, eval_res=128)
    from morf.fitting.evaluate import silhouettes

    with torch.no_grad():
        fat = dressed_vertices(body_model, body_model(pose, SHAPE), SHAPE,
                               torch.full((body_model.dense_weights.shape[0],), 0.025))
        full = silhouettes(fat, body_model.faces, inputs.camera, 1.0, size, size)
    sw, sh, _ = raster_size(size, size, 128)
    masks = np.stack([downsample_mask(m, sw, sh) for m in full])
    inputs = FitInputs(inputs.keypoints, inputs.detected, inputs.camera, masks, inputs.mask_scale,
                       masks >= 0.5, inputs.eval_scale)
    cfg = preset("fast").replace(silhouette_resolution=128, iou_resolution=128, silhouette_frame_fraction=1.0)
    state = fit_sequence(body_model, inputs, cfg, device=torch.device("cpu"))
    assert state.offsets.numel() == len(body_proxy(body_model, cfg.proxy_cell).vertex_ids)
    assert float(state.offsets.mean()) > 0.003  # 24 short steps of the "fast" preset: part of the 25 mm
    assert float(state.offsets.min()) >= cfg.offset_min and float(state.offsets.max()) <= cfg.offset_max + 1e-6
    fits, _ = finalize(body_model, inputs, cfg, state)
    assert fits.offsets is not None and fits.offsets.shape == (body_model.dense_weights.shape[0],)
    assert np.mean(fits.silhouette_iou) > np.mean(fits.silhouette_iou_body) + 0.02
