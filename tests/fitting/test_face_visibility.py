"""The face points a pose detector reports, as the fit takes them: hidden ones (a nose and eyes
guessed on the back of the head, the far ear of a profile) do not count, and the ears sit where a
detector marks them. A fit to such evidence keeps its head where the body's head is."""

import dataclasses
import math

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.fitting import fit_sequence, preset
from morf.fitting.fit import FitState
from morf.fitting.face_visibility import (LEFT_EAR, RIGHT_EAR, detector_ear_offsets, detector_ears,
                                          ear_offsets_per_frame, face_point_visibility, weight_face_points)

from .synthetic import SHAPE, make_inputs

# a head of the rest pose's proportions facing -y (Anny's front), left at +x: nose, eyes, ears
HEAD = torch.tensor([[0.0, -0.14, 0.615], [0.03, -0.12, 0.646], [-0.03, -0.12, 0.646],
                     [0.074, -0.038, 0.627], [-0.074, -0.038, 0.627]])


def _turned(deg: float) -> torch.Tensor:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    R = torch.tensor([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return (HEAD @ R.T)[None]


def test_visibility_follows_the_heads_turn():
    camera = torch.tensor([0.0, -3.0, 0.6])  # in front of the rest pose
    front = face_point_visibility(_turned(0), camera)[0]
    assert torch.allclose(front, torch.ones(5))  # both ears on the outline count
    back = face_point_visibility(_turned(180), camera)[0]
    assert back[:3].max() == 0 and back[3:].min() == 1  # nose and eyes hidden, ears seen
    # turned 90 degrees to its right: the left ear faces the camera, the right ear and eye are hidden
    right = face_point_visibility(_turned(-90), camera)[0]
    assert right[0] > 0.9 and right[1] == 1 and right[3] == 1  # the nose on the profile's outline
    assert right[2] == 0 and right[4] == 0
    detected = torch.cat([torch.zeros(1, 23, 2), torch.ones(1, 23, 1)], -1)
    weighted = weight_face_points(detected, back[None])
    assert weighted[0, :3, 2].max() == 0 and weighted[0, 3:, 2].min() == 1


def test_detector_ears_turn_with_the_head():
    kp = torch.zeros(2, 23, 3)
    turn = torch.tensor([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 degrees about z
    out = detector_ears(kp, torch.stack([torch.eye(3), turn]), detector_ear_offsets())
    off = detector_ear_offsets()
    per_frame = ear_offsets_per_frame(np.array(["mediapipe", "openpose"]), True)
    assert torch.allclose(per_frame[0], off) and per_frame[1].abs().max() == 0  # OpenPose marks COCO's ears
    assert ear_offsets_per_frame(np.array(["ground_truth"]), True) is None
    assert ear_offsets_per_frame(np.array(["mediapipe"]), False) is None
    assert torch.allclose(out[0, LEFT_EAR], off[0]) and torch.allclose(out[0, RIGHT_EAR], off[1])
    assert torch.allclose(out[1, LEFT_EAR], turn @ off[0])
    assert out[:, :LEFT_EAR].abs().max() == 0 and out[:, RIGHT_EAR + 1:].abs().max() == 0
    assert off[0, 0] < 0 < off[1, 0] and (off[:, 1] < 0).all()  # both nearer the midline and the face


def _detector_evidence(model, pose, inputs):
    """The keypoints a detector reports for ``pose``: ears where a detector marks them, and in the
    views turned away guesses at the hidden face points 8 px above where they are."""
    with torch.no_grad():
        out = model(pose, SHAPE)
        k3 = detector_ears(out.keypoints3d, out.bone_transforms[:, model.bone_index("head"), :3, :3],
                           detector_ear_offsets())
        px = inputs.camera.project(k3).numpy()
        seen = face_point_visibility(k3, torch.as_tensor(inputs.camera.position, dtype=torch.float32)).numpy()
    pts = inputs.keypoints.copy()
    pts[:, 3:5, :2] = px[:, 3:5]
    hidden = seen < 0.5
    pts[:, :5, 1] -= 8.0 * hidden
    return dataclasses.replace(inputs, keypoints=pts.astype(np.float32), unordered=True,
                               keypoint_source=np.full(len(pts), "mediapipe"))


def _head_in_body_deg(model, rotvecs, truth) -> np.ndarray:
    """(N,) angle between the fitted and the true head orientation relative to the root."""
    def rel(rv):
        with torch.no_grad():
            out = model(BodyPose(torch.as_tensor(rv), truth.transl), SHAPE)
        T = out.bone_transforms[:, [0, model.bone_index("head")], :3, :3]
        return T[:, 0].transpose(1, 2) @ T[:, 1]

    cos = ((rel(rotvecs) * rel(truth.rotvecs)).sum((1, 2)) - 1) / 2
    return np.degrees(np.arccos(cos.clamp(-1, 1).numpy()))


def test_hidden_face_guesses_do_not_tilt_the_head(body_model):
    """The body stage started from the true pose (the first stage's job done right): with the
    detector's guesses taken as evidence the head turns away from the truth; seen as hidden, with
    the ears where the detector marks them and the head held upright where the face is hidden, it
    stays."""
    n = 4
    rot = torch.zeros(n, len(body_model.bone_names), 3)
    rot[:, 0, 2] = torch.tensor(np.radians([0.0, 90.0, 150.0, 180.0]), dtype=torch.float32)
    rot[:, body_model.bone_index("upperarm01.L"), 1] = -0.3
    pose = BodyPose(rot, torch.zeros(n, 3))
    inputs, _ = make_inputs(body_model, pose, SHAPE, size=256, noise_px=0.0, sil_res=64, eval_res=64)
    inputs = _detector_evidence(body_model, pose, inputs)
    start = FitState(pose.rotvecs.clone(), pose.transl.clone(), SHAPE.clone(), stage=1)
    errors = {}
    for name, cfg in (("now", preset("tiny")),
                      ("before", preset("tiny").replace(detector_ears=False, face_visibility=False,
                                                        head_prior_weight=0.0, head_prior_hidden_weight=0.0))):
        cfg = cfg.replace(overlays=False, frame_filter=False, silhouette=False).with_settings(["stages.1.iterations=60"])
        state = fit_sequence(body_model, inputs, cfg, start=start)
        errors[name] = _head_in_body_deg(body_model, state.rotvecs, pose)
    assert errors["now"].max() < 8.0, errors
    assert errors["before"][1:].min() > 20.0, errors  # the views turned away, where the guesses act


def test_face_points_count_less_where_the_face_mesh_found_no_face():
    from morf.fitting.face_visibility import trust_found_faces

    kp = np.ones((3, 23, 3), np.float32)
    lm = np.zeros((3, 49, 3), np.float32)
    lm[0, :5, 2] = 1.0  # a face found in frame 0 only
    out = trust_found_faces(kp, lm, 0.25)
    assert np.array_equal(out[0], kp[0])
    assert np.allclose(out[1:, :3, 2], 0.25) and np.allclose(out[1:, 3:, 2], 1.0)  # nose, eyes; ears and body kept
    assert np.array_equal(kp, np.ones_like(kp))  # the input is not changed
    assert trust_found_faces(kp, np.zeros_like(lm), 0.0) is kp  # no face anywhere: nothing to go by
    assert trust_found_faces(kp, None, 0.0) is kp and trust_found_faces(kp, lm, 1.0) is kp


def test_faceless_weight_is_checked():
    import pytest

    from morf.errors import InputError

    with pytest.raises(InputError, match="faceless_face_weight"):
        preset("default").replace(faceless_face_weight=1.5)
