"""The head-and-hands term: the landmark points on the body, the term, and the refinement that
brings a turned head and turned wrists back to where their landmarks put them."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from morf.body import BodyPose
from morf.camera import PinholeCamera
from morf.fitting.head_hands import (HEAD_BONES, NUM_POINTS, WRIST_BONES, HeadHandsConfig, LandmarkPoser,
                                     fit_head_hands, head_hands_term, landmark_index, landmark_points3d,
                                     landmark_targets)


@pytest.fixture(scope="module")
def scene(body_model):
    """Two frames of a person facing a camera 2.2 m away, arms a little raised, fingers at rest."""
    cam = PinholeCamera.look_at(384, 384, 28.0, eye=(0.0, -2.2, 0.0), target=(0.0, 0.0, 0.0))
    rng = np.random.default_rng(0)
    rot = np.zeros((2, len(body_model.bone_names), 3), np.float32)
    rot[:, 0] = rng.normal(0, 0.15, (2, 3))
    for b in ("upperarm01.L", "upperarm01.R", "neck01", "lowerarm01.L"):
        rot[:, body_model.bone_index(b)] = rng.normal(0, 0.2, (2, 3))
    return cam, rot, np.zeros((2, 3), np.float32), body_model.default_shape().numpy()


def _global_rotations(model, rot, transl, shape, bones):
    with torch.no_grad():
        out = model(BodyPose(torch.as_tensor(rot), torch.as_tensor(transl)), torch.as_tensor(shape))
    return out.bone_transforms[:, [model.bone_index(b) for b in bones], :3, :3]


def _angle_deg(a, b):
    c = (((a.transpose(-1, -2) @ b).diagonal(dim1=-2, dim2=-1).sum(-1) - 1) / 2).clamp(-1, 1)
    return torch.rad2deg(torch.arccos(c)).numpy()


def _truth(model, cam, rot, transl, shape):
    with torch.no_grad():
        out = model(BodyPose(torch.as_tensor(rot), torch.as_tensor(transl)), torch.as_tensor(shape))
        px = cam.project(landmark_points3d(landmark_index(model), out)).numpy()
    return np.concatenate([px, np.ones(px.shape[:2] + (1,), np.float32)], -1)


def test_points_sit_on_the_face_and_the_hands(body_model, scene):
    cam, rot, transl, shape = scene
    with torch.no_grad():
        out = body_model(BodyPose(torch.as_tensor(rot), torch.as_tensor(transl)), torch.as_tensor(shape))
    pts = landmark_points3d(landmark_index(body_model), out)
    assert pts.shape == (2, NUM_POINTS, 3)
    fast = LandmarkPoser(body_model, torch.as_tensor(shape))(BodyPose(torch.as_tensor(rot), torch.as_tensor(transl)))
    assert (fast - pts).abs().max() < 1e-4  # the few skinned vertices and the ears on the head bone
    at_rest = body_model(body_model.zero_pose(), body_model.default_shape())
    rest = landmark_points3d(landmark_index(body_model), at_rest)[0]
    right_eye, left_eye, nose, mouth, chin, right_ear, left_ear = rest[:7].numpy()
    assert right_eye[0] < 0 < left_eye[0] and right_ear[0] < right_eye[0] and left_ear[0] > left_eye[0]
    assert nose[1] < right_eye[1] and nose[1] < mouth[1] < chin[1] + 0.03  # the nose in front (the body faces -Y)
    assert right_eye[2] > nose[2] > mouth[2] > chin[2]
    left_wrist, left_tips = rest[7].numpy(), rest[[11, 15, 19, 23, 27]].numpy()
    assert left_wrist[0] > 0.3 and (np.linalg.norm(left_tips - left_wrist, axis=1) > 0.06).all()
    assert np.linalg.norm(rest[7 + 12] - rest[28 + 12] * torch.tensor([-1.0, 1, 1])) < 0.01  # mirrored hands


def test_term_is_zero_at_the_landmarks_and_ignores_thin_evidence(body_model, scene):
    cam, rot, transl, shape = scene
    tgt = torch.as_tensor(_truth(body_model, cam, rot, transl, shape))
    px = tgt[..., :2].clone()
    assert head_hands_term(px, tgt, 384).abs().max() < 1e-9
    moved = px + 3.0
    full = head_hands_term(moved, tgt, 384)
    assert (full > 0).all()
    thin = tgt.clone()
    thin[:, 7:, 2] = 0
    thin[:, 7:9, 2] = 1  # two points of a hand are not a hand
    face_only = torch.cat([tgt[:, :7], torch.zeros_like(tgt[:, 7:])], 1)
    assert torch.allclose(head_hands_term(moved, thin, 384), head_hands_term(moved, face_only, 384))
    x = torch.randn(1, NUM_POINTS, 2, dtype=torch.float64, requires_grad=True)
    t = torch.cat([torch.randn(1, NUM_POINTS, 2), torch.rand(1, NUM_POINTS, 1)], -1).double()
    assert torch.autograd.gradcheck(lambda p: head_hands_term(p, t, 100), (x,))


def test_refinement_brings_the_head_and_wrists_back(body_model, scene):
    """Head and wrists turned about 15 degrees off a pose whose landmarks are known: the
    refinement returns them to within a few degrees and leaves every other bone alone."""
    cam, rot, transl, shape = scene
    tgt = _truth(body_model, cam, rot, transl, shape)
    bones = ("head", "wrist.L", "wrist.R")
    off = rot.copy()
    rng = np.random.default_rng(3)
    for b in bones:
        off[:, body_model.bone_index(b)] += rng.normal(0, 0.15, (2, 3)).astype(np.float32)
    true_R = _global_rotations(body_model, rot, transl, shape, bones)
    before = _angle_deg(_global_rotations(body_model, off, transl, shape, bones), true_R)
    res = fit_head_hands(body_model, off, transl, shape, cam, tgt, HeadHandsConfig(fingers=False, prior=0.5))
    after = _angle_deg(_global_rotations(body_model, res.rotvecs, transl, shape, bones), true_R)
    assert before.mean() > 8 and after.max() < 3, (before, after)
    assert (res.residual_after < 0.5).all() and (res.residual_before > 1).all()
    moved = np.abs(res.rotvecs - off).reshape(2, -1, 3).max(axis=(0, 2)) > 0
    assert {body_model.bone_names[j] for j in np.nonzero(moved)[0]} <= set(HEAD_BONES + WRIST_BONES)


def test_frames_without_evidence_stay_as_they_are(body_model, scene):
    cam, rot, transl, shape = scene
    face = np.zeros((2, 5, 3), np.float32)
    hands = np.zeros((2, 21, 3), np.float32)
    tgt = landmark_targets(face, hands, hands, body=np.ones((2, 23, 3), np.float32))
    assert tgt.shape == (2, NUM_POINTS, 3) and not tgt[..., 2].any()  # no face: the ears do not count either
    res = fit_head_hands(body_model, rot, transl, shape, cam, tgt, HeadHandsConfig(steps=5))
    np.testing.assert_array_equal(res.rotvecs, rot)
    assert np.isnan(res.residual_before).all()


def _head_points(yaw_deg: float) -> torch.Tensor:
    """(1, 49, 3) landmark points (landmark_points3d's order) of a head 2 m in front of a camera
    at the origin, facing it when ``yaw_deg`` is 0, turned about the vertical by ``yaw_deg``."""
    a = math.radians(yaw_deg)
    R = torch.tensor([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
    # in the head's frame: the face towards -z (the camera), the person's left towards +x
    local = torch.tensor([[-0.03, 0.03, -0.085], [0.03, 0.03, -0.085], [0.0, 0.0, -0.1], [0.0, -0.04, -0.09],
                          [0.0, -0.08, -0.08], [-0.075, 0.02, 0.0], [0.075, 0.02, 0.0]])
    pts = torch.zeros(1, 49, 3)
    pts[0, :7] = local @ R.T + torch.tensor([0.0, 0.0, 2.0])
    return pts


def test_profile_faces_do_not_count():
    """The face mesh's far eye is a guess in a profile (it drew a face turned 50 degrees where the
    head was turned 85): a face counts only where the pose turns both eyes towards the camera."""
    from types import SimpleNamespace

    from morf.fitting.head_hands import NUM_FACE, hide_profile_faces

    camera = SimpleNamespace(position=np.zeros(3))
    targets = torch.ones(1, 49, 3)
    kept = {yaw: float(hide_profile_faces(targets, _head_points(yaw), camera, 0.5)[0, :NUM_FACE, 2].min())
            for yaw in (0, 30, -30, 85, -85, 120)}
    assert kept == {0: 1.0, 30: 1.0, -30: 1.0, 85: 0.0, -85: 0.0, 120: 0.0}
    out = hide_profile_faces(targets, _head_points(85), camera, 0.5)
    assert bool((out[0, NUM_FACE:, 2] == 1).all())  # the hands keep their evidence


def test_faces_count_less_the_further_the_head_turns():
    """The face mesh draws a turned face less turned than it is: its weight falls from full at
    ``face_yaw_full`` degrees to nothing at ``face_yaw_none``, and the hands keep theirs."""
    from types import SimpleNamespace

    from morf.fitting.head_hands import NUM_FACE, face_yaw_weights, head_yaw_deg

    camera = SimpleNamespace(position=np.zeros(3))
    targets = torch.ones(1, 49, 3)
    yaws = (0, 20, -20, 40, 50, 70, -70, 85, 120)
    angle = {y: float(head_yaw_deg(_head_points(y), camera)[0]) for y in yaws}
    assert angle[0] < 15 and abs(angle[85] - 85) < 10 and angle[120] > 110  # the face's own tilt at 0
    kept = {y: float(face_yaw_weights(targets, _head_points(y), camera, 30.0, 60.0)[0, :NUM_FACE, 2].min())
            for y in yaws}
    assert kept[0] == kept[20] == kept[-20] == 1.0
    assert 1.0 > kept[40] > kept[50] > 0.0
    assert kept[70] == kept[-70] == kept[85] == kept[120] == 0.0
    out = face_yaw_weights(targets, _head_points(85), camera, 30.0, 60.0)
    assert bool((out[0, NUM_FACE:, 2] == 1).all())
    assert torch.equal(face_yaw_weights(targets, _head_points(85), camera, 30.0, 180.0), targets)


def test_neighbours_carry_the_head_across_a_frame_without_a_face(body_model, scene):
    """A face found in frames 0 and 2 but not in 1 (a detector that loses it for a frame): alone,
    frame 1 keeps its turned head; tied to its neighbours, it comes most of the way with them."""
    cam, rot, transl, shape = scene
    rot3 = np.repeat(rot[:1], 3, 0)
    tr3 = np.repeat(transl[:1], 3, 0)
    tgt = _truth(body_model, cam, rot3, tr3, shape)
    tgt[:, 7:, 2] = 0  # the face alone
    tgt[1, :, 2] = 0
    off = rot3.copy()
    off[:, body_model.bone_index("head")] += np.array([0.0, 0.0, 0.25], np.float32)  # about 14 degrees
    true_R = _global_rotations(body_model, rot3, tr3, shape, ("head",))
    alone = fit_head_hands(body_model, off, tr3, shape, cam, tgt, HeadHandsConfig(fingers=False))
    tied = fit_head_hands(body_model, off, tr3, shape, cam, tgt, HeadHandsConfig(fingers=False), np.ones(2))
    err_alone = _angle_deg(_global_rotations(body_model, alone.rotvecs, tr3, shape, ("head",)), true_R)[:, 0]
    err_tied = _angle_deg(_global_rotations(body_model, tied.rotvecs, tr3, shape, ("head",)), true_R)[:, 0]
    np.testing.assert_array_equal(alone.rotvecs[1], off[1])
    assert err_alone[1] > 12 and err_tied[1] < 0.5 * err_alone[1], (err_alone, err_tied)
    assert max(err_tied[0], err_tied[2], err_alone[0], err_alone[2]) < 5, (err_alone, err_tied)
    no_link = fit_head_hands(body_model, off, tr3, shape, cam, tgt, HeadHandsConfig(fingers=False, temporal=0.0),
                             np.ones(2))
    np.testing.assert_array_equal(no_link.rotvecs[1], off[1])
