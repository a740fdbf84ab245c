"""numpy forward kinematics of the exported skeleton against the body model's own bone transforms."""

import numpy as np
import torch

from morf.body import BodyPose
from morf.export.skeleton import rotvec_to_matrix_rodrigues, skeleton_from_body_model


def test_rotvec_to_matrix_matches_torch():
    from morf.body.rotations import axis_angle_to_matrix

    r = np.random.default_rng(0).normal(size=(50, 3)) * 1.5
    r[0] = 0
    r[1] = 1e-9
    ref = axis_angle_to_matrix(torch.from_numpy(r)).numpy()
    np.testing.assert_allclose(rotvec_to_matrix_rodrigues(r), ref, atol=1e-10)


def test_numpy_fk_matches_body_model(body_model):
    shape = torch.tensor([[0.3, 0.7, 0.6, 0.4, 0.55, 0.45]])
    skel = skeleton_from_body_model(body_model, shape)
    rng = np.random.default_rng(1)
    rotvecs = rng.normal(scale=0.4, size=(2, skel.num_bones, 3)).astype(np.float32)
    transl = rng.normal(scale=0.5, size=(2, 3)).astype(np.float32)
    with torch.no_grad():
        out = body_model(BodyPose(torch.from_numpy(rotvecs), torch.from_numpy(transl)), shape)
    for b in range(2):
        T = skel.bone_transforms(rotvecs[b], transl[b])
        np.testing.assert_allclose(T, out.bone_transforms[b].numpy(), atol=2e-5)
    assert not np.allclose(T[5], np.eye(4), atol=1e-2)  # the pose really moved the bones
