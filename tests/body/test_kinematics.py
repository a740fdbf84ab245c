"""Our batched-matmul forward kinematics against Anny's own."""

import pytest
import torch

from morf.body.model import BodyPose


@pytest.fixture(scope="module")
def model(body_model):
    """The session's Anny (loaded once for all test files), read only here."""
    return body_model


@pytest.mark.parametrize("shared_rest", [True, False])
def test_matches_anny_forward_kinematics(model, shared_rest):
    assert model._chain is not None  # Anny's default parameterization is the one implemented
    g = torch.Generator().manual_seed(0)
    B, J = 5, len(model.bone_names)
    shape = model.default_shape() if shared_rest else torch.rand(B, model.shape_dim, generator=g) * 0.4 + 0.3
    rest = model.rest(shape)["rest_bone_poses"]
    pose = BodyPose(torch.randn(B, J, 3, generator=g) * 0.4, torch.randn(B, 3, generator=g))
    T, W = model.bone_transforms(pose, rest)
    ref_rest = rest.expand(B, -1, -1, -1) if rest.shape[0] == 1 else rest
    T_ref, W_ref = model.anny.get_bone_transforms(model.pose_to_deltas(pose), ref_rest)
    torch.testing.assert_close(T, T_ref, rtol=1e-4, atol=2e-5)
    torch.testing.assert_close(W, W_ref, rtol=1e-4, atol=2e-5)


def test_gradients_match_anny(model):
    g = torch.Generator().manual_seed(1)
    J = len(model.bone_names)
    rest = model.rest(model.default_shape())["rest_bone_poses"]
    rv = (torch.randn(3, J, 3, generator=g) * 0.3).requires_grad_(True)
    tr = torch.randn(3, 3, generator=g).requires_grad_(True)
    weights = torch.randn(3, J, 4, 4, generator=g)
    T, _ = model.bone_transforms(BodyPose(rv, tr), rest)
    ours = torch.autograd.grad((T * weights).sum(), (rv, tr))
    T_ref, _ = model.anny.get_bone_transforms(model.pose_to_deltas(BodyPose(rv, tr)), rest.expand(3, -1, -1, -1))
    ref = torch.autograd.grad((T_ref * weights).sum(), (rv, tr))
    for a, b in zip(ours, ref):
        torch.testing.assert_close(a, b, rtol=1e-3, atol=1e-4)


def test_chain_from_parents_orders_levels_and_rejects_bad_trees():
    from morf.body.kinematics import KinematicChain

    chain = KinematicChain.from_parents([-1, 0, 1, 0, 3, 3])
    assert chain.levels == ((0, 1), (1, 3), (3, 6))
    assert chain.order.tolist() == [0, 1, 3, 2, 4, 5]
    assert chain.local.tolist() == [0, 0, 0, 0, 1, 1]
    assert chain.order[chain.inverse].tolist() == list(range(6))
    with pytest.raises(ValueError):
        KinematicChain.from_parents([0, 0])
    with pytest.raises(ValueError):
        KinematicChain.from_parents([-1, 2, 1])


def test_fit_pose_matrices_pose_the_body_as_its_axis_angles(model):
    from morf.fitting.params import FIT_BONES, FitParameters
    from morf.body.rotations import axis_angle_to_matrix

    g = torch.Generator().manual_seed(2)
    N = 4
    bone_ids = [model.bone_index(b) for b in FIT_BONES]
    root = axis_angle_to_matrix(torch.randn(N, 3, generator=g))
    params = FitParameters(N, len(model.bone_names), bone_ids, root, torch.randn(N, 3, generator=g),
                           model.default_shape(), True)
    with torch.no_grad():
        params.body.normal_(0, 0.4, generator=g)
        params.root_delta.normal_(0, 0.2, generator=g)
    rest = model.rest(model.default_shape())["rest_bone_poses"]
    T_mat, _ = model.bone_transforms(params.pose_matrices(), rest)
    T_vec, _ = model.bone_transforms(params.pose(), rest)
    torch.testing.assert_close(T_mat, T_vec, rtol=1e-4, atol=2e-5)
    torch.testing.assert_close(model.pose_to_deltas(params.pose_matrices()), model.pose_to_deltas(params.pose()),
                               rtol=1e-4, atol=2e-5)
