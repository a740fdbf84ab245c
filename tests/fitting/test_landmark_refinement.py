"""The fit's last step turns the head and the wrists to the face and hand landmarks when the
inputs have them; frames fitted with exchanged left/right labels have their hands exchanged too."""

import dataclasses

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.fitting import finalize, fit_sequence, preset
from morf.fitting.head_hands import landmark_index, landmark_points3d, landmark_targets
from morf.fitting.landmark_refinement import exchange_landmark_labels

from .synthetic import SHAPE, make_inputs


def test_exchanging_labels_swaps_the_hands_eyes_and_ears():
    t = np.arange(49 * 3, dtype=np.float32).reshape(1, 49, 3).repeat(2, 0)
    out = exchange_landmark_labels(t, np.array([False, True]))
    assert (out[0] == t[0]).all()
    assert (out[1, 0] == t[1, 1]).all() and (out[1, 2] == t[1, 2]).all() and (out[1, 5] == t[1, 6]).all()
    assert (out[1, 7:28] == t[1, 28:49]).all() and (out[1, 28:49] == t[1, 7:28]).all()
    assert exchange_landmark_labels(t, None) is t


def _head_and_wrists(model, rotvecs, transl):
    with torch.no_grad():
        out = model(BodyPose(torch.as_tensor(rotvecs), torch.as_tensor(transl)), SHAPE)
    return out.bone_transforms[:, [model.bone_index(b) for b in ("head", "wrist.L", "wrist.R")], :3, :3]


def test_finalize_turns_the_head_and_wrists_to_the_landmarks(body_model):
    n = 3
    rot = torch.zeros(n, len(body_model.bone_names), 3)
    rng = np.random.default_rng(1)
    for b in ("head", "neck01", "wrist.L", "wrist.R"):
        rot[:, body_model.bone_index(b)] = torch.as_tensor(rng.normal(0, 0.35, (n, 3)), dtype=torch.float32)
    pose = BodyPose(rot, torch.zeros(n, 3))
    inputs, out = make_inputs(body_model, pose, SHAPE, size=256, sil_res=64, eval_res=64)
    px = inputs.camera.project(landmark_points3d(landmark_index(body_model), out)).numpy()
    lm = np.concatenate([px, np.ones(px.shape[:2] + (1,), np.float32)], -1)
    targets = landmark_targets(lm[:, :5], lm[:, 7:28], lm[:, 28:49], inputs.keypoints)
    inputs = dataclasses.replace(inputs, landmarks=targets)
    cfg = preset("tiny").replace(overlays=False)
    state = fit_sequence(body_model, inputs, cfg, device=torch.device("cpu"))
    with_lm, _ = finalize(body_model, inputs, cfg, state)
    without, _ = finalize(body_model, inputs, cfg.replace(head_hands=False), state)
    true = _head_and_wrists(body_model, rot, pose.transl)

    def err(fits):
        R = _head_and_wrists(body_model, torch.as_tensor(fits.rotvecs), torch.as_tensor(fits.transl))
        c = (((R.transpose(-1, -2) @ true).diagonal(dim1=-2, dim2=-1).sum(-1) - 1) / 2).clamp(-1, 1)
        return torch.rad2deg(torch.arccos(c)).numpy()

    e_with, e_without = err(with_lm), err(without)
    assert without.landmark_residual_px is None and with_lm.landmark_residual_px.shape == (n, 3)
    assert e_with[:, 1:].mean() < 0.6 * e_without[:, 1:].mean()  # the wrists: the keypoints barely see their turn
    assert e_with[:, 0].mean() < e_without[:, 0].mean()
    # the rest of the body stays where the stages put it
    others = [i for i in range(len(body_model.bone_names)) if body_model.bone_names[i] in ("spine02", "upperleg01.L")]
    assert np.allclose(with_lm.rotvecs[:, others], without.rotvecs[:, others])


def test_changes_are_smoothed_over_video_neighbours_only():
    from morf.fitting.landmark_refinement import smooth_changes

    before = np.zeros((5, 2, 3), np.float32)
    after = before.copy()
    after[2, 0, 0] = 1.0  # one frame's change
    video = smooth_changes(before, after, np.ones(4))
    assert video[2, 0, 0] < 0.5 and video[1, 0, 0] > 0 and video[3, 0, 0] > 0
    assert np.isclose(video[:, 0, 0].sum(), 1.0, atol=0.15) and (video[:, 1] == 0).all()
    # unordered views, or frames far apart, keep their own change
    assert np.array_equal(smooth_changes(before, after, None), after)
    apart = smooth_changes(before, after, np.array([1.0, 4.0, 4.0, 1.0]))
    assert np.allclose(apart, after)
