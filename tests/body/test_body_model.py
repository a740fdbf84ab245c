import numpy as np
import torch

from morf.body.model import BodyPose
from morf.body.render_mesh import render_mesh_for
from morf.body.rotations import axis_angle_to_matrix, matrix_to_axis_angle


def _random_pose(model, B=3, seed=0, scale=0.3):
    g = torch.Generator().manual_seed(seed)
    J = len(model.bone_names)
    return BodyPose(scale * torch.randn(B, J, 3, generator=g), torch.randn(B, 3, generator=g))


def test_skinning_matches_anny(body_model):
    pose = _random_pose(body_model)
    shape = torch.tensor([[0.3, 0.6, 0.4, 0.7, 0.2, 0.55]]).repeat(3, 1)
    out = body_model(pose, shape)
    ref = body_model.anny(body_model.pose_to_deltas(pose), shape)
    assert torch.allclose(out.vertices, ref["vertices"], atol=1e-5)
    assert torch.allclose(out.joints, ref["bone_poses"][..., :3, 3], atol=1e-5)


def test_zero_pose_is_upright_a_pose(body_model):
    out = body_model(body_model.zero_pose(1), body_model.default_shape())
    v = out.vertices[0]
    height = (v[:, 2].max() - v[:, 2].min()).item()
    assert 1.4 < height < 1.9
    kp = out.keypoints3d[0]
    assert kp[5, 0] > kp[6, 0]  # left shoulder at +X
    assert kp[0, 2] > kp[11, 2] > kp[15, 2]  # nose above hip above ankle


def test_render_mesh_reproduces_surface(body_model):
    rm = render_mesh_for(body_model)
    faces = body_model.faces.numpy()
    assert rm.num_vertices > body_model.num_vertices
    # every render triangle is the original triangle, through the vertex map
    assert np.array_equal(rm.vertex_map[rm.faces], faces)
    # and carries the original per-corner UVs
    uv_orig = body_model.uvs.numpy()[body_model.face_uvs.numpy()]
    assert np.allclose(rm.uvs[rm.faces], uv_orig)
    # top-k skinning reproduces the dense skinning closely
    pose = _random_pose(body_model, B=1, scale=0.4)
    out = body_model(pose, body_model.default_shape())
    T = out.bone_transforms[0].numpy()
    rest = out.rest_vertices[0].numpy()[rm.vertex_map]
    M = np.einsum("vk,vkij->vij", rm.bone_weights, T[rm.bone_indices])
    skinned = np.einsum("vij,vj->vi", M[:, :3, :3], rest) + M[:, :3, 3]
    ref = out.vertices[0].numpy()[rm.vertex_map]
    assert np.abs(skinned - ref).max() < 2e-3


def test_gradients_reach_pose_and_shape(body_model):
    pose = _random_pose(body_model, B=2)
    rot = pose.rotvecs.clone().requires_grad_(True)
    tr = pose.transl.clone().requires_grad_(True)
    shape = body_model.default_shape().clone().requires_grad_(True)
    out = body_model(BodyPose(rot, tr), shape)
    (out.vertices.square().mean() + out.keypoints3d.square().mean()).backward()
    for g in (rot.grad, tr.grad, shape.grad):
        assert g is not None and torch.isfinite(g).all() and g.abs().sum() > 0


def test_rotation_roundtrip_and_gradcheck():
    v = torch.randn(20, 3, dtype=torch.float64)
    R = axis_angle_to_matrix(v * 0.5)
    assert torch.allclose(R @ R.transpose(-1, -2), torch.eye(3, dtype=torch.float64).expand(20, 3, 3), atol=1e-10)
    assert torch.allclose(axis_angle_to_matrix(matrix_to_axis_angle(R)), R, atol=1e-8)
    x = (0.5 * torch.randn(4, 3, dtype=torch.float64)).requires_grad_(True)
    assert torch.autograd.gradcheck(axis_angle_to_matrix, (x,))
    z = torch.zeros(1, 3, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(axis_angle_to_matrix, (z,))


def test_keypoint_layout_is_annys_regressor_order(body_model):
    import anny

    from morf.capture.keypoint_layout import KEYPOINT_NAMES

    assert list(KEYPOINT_NAMES) == list(anny.KeypointsRegressor.coco(body_model.anny).labels)
