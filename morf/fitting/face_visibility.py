"""The body keypoints' face points (nose, eyes, ears) as a pose detector reports them: which of
them the camera can see on a posed head, and where on the head it marks an ear.

A pose detector reports every face point with full confidence, the hidden ones too: on a back
view MediaPipe puts a nose and two eyes on the back of the head, on a side view the far ear and
the far eye are guesses beside the near ones. Those guesses are biased (on the default synthetic
capture the back views' noses sat 8 px above where the hidden nose projects), and fitted as
evidence they tilted the fitted head about the camera's horizontal axis by 13-16 degrees on
average in the side and back views. The fit therefore weights each face point by whether the body
it is fitting turns that point towards the camera (:func:`face_point_visibility`), as a person
labelling the image would. The weights are taken from the pose a stage starts from and held
through the stage, so a head cannot turn towards a guessed face to make it count (recomputed at
every step, a test view at 150 degrees with one ear to go by ended 47 degrees off, 22 held).

A detector's ear is not the body model's COCO ear either: Anny's regressor puts the ear in the
middle of the auricle, which stands out from the skull behind the cheek, while MediaPipe marks
the ear on the cheek in a front view and ahead of the auricle in a profile, near the ear canal.
Fitted to the truth's poses (least squares, one point per ear in the head's frame, the frames
where the ear faces the camera), MediaPipe's ears on the default synthetic capture lay 1.65-1.85
cm nearer the midline and 2.5-3.2 cm further forward than the model's ears; in height 0.9 cm
above them in the front views and 0.3-0.7 cm in the side views (where MediaPipe put the nose and
eyes 3-5 px above the truth as well). :data:`DETECTOR_EAR_OFFSET` takes 1.8 cm, 2.85 cm and the
middle of the heights, 0.45 cm (0, 0.45 and 0.9 cm gave the same head error to within a run's
noise). On a real photo (the front view of ``../shared/data/images/ryota.png``) MediaPipe's ears
were 1.80 eye distances apart, against 1.91 for the moved points and 2.5 for the model's own ears.
"""

from __future__ import annotations

import math

import numpy as np
import torch

NOSE, LEFT_EYE, RIGHT_EYE, LEFT_EAR, RIGHT_EAR = range(5)  # COCO order of the body keypoints
# the eyes look out this far to their own side of straight ahead: the far eye hides behind the
# nose bridge once the head has turned about 60 degrees away from the camera
EYE_SPREAD_DEG = 30.0
# a point counts fully where its outward direction is at most 90 degrees from the direction to
# the camera and not at all beyond about 107 degrees (cos = -0.3): a point on the outline (an ear
# in a front view, the nose in profile) is seen
SEEN_COS, HIDDEN_COS = 0.0, -0.3
# a detector's left ear against the body model's (metres, rest-pose axes: x the person's left,
# y backwards, z up); the right ear mirrors it
DETECTOR_EAR_OFFSET = (-0.018, -0.0285, 0.0045)


def detector_ear_offsets() -> torch.Tensor:
    """(2, 3) where a detector marks the left and the right ear (COCO keypoints 3 and 4) against the
    body model's ears, in the head bone's rest-pose axes, metres."""
    x, y, z = DETECTOR_EAR_OFFSET
    return torch.tensor([[x, y, z], [-x, y, z]])


def detector_ears(keypoints3d: torch.Tensor, head_rotation: torch.Tensor, offsets: torch.Tensor) -> torch.Tensor:
    """``keypoints3d`` (B, K, 3) world keypoints in COCO order with the ears (3 and 4) moved by
    ``offsets`` (2, 3) or per frame (B, 2, 3) (:func:`detector_ear_offsets`; zeros keep the
    model's ears) turned with the head: ``head_rotation`` (B, 3, 3) the head bone's skinning
    rotation (identity in the rest pose)."""
    offsets = offsets.to(keypoints3d).expand(keypoints3d.shape[0], 2, 3)
    moved = keypoints3d[:, LEFT_EAR:RIGHT_EAR + 1] + torch.einsum("bij,bkj->bki", head_rotation, offsets)
    return torch.cat([keypoints3d[:, :LEFT_EAR], moved, keypoints3d[:, RIGHT_EAR + 1:]], 1)


def detector_frames(keypoint_source, num_frames: int) -> torch.Tensor:
    """(N,) bool: the frames whose keypoints a detector guessed, hidden face points included (every
    frame but those whose keypoints are the truth's own, ``keypoint_source`` "ground_truth"; all
    when the source is unknown)."""
    if keypoint_source is None:
        return torch.ones(num_frames, dtype=torch.bool)
    return torch.as_tensor([str(s) != "ground_truth" for s in keypoint_source], dtype=torch.bool)


def ear_offsets_per_frame(keypoint_source, enabled: bool) -> torch.Tensor | None:
    """(N, 2, 3) the ears' offsets of each frame: :func:`detector_ear_offsets` where its keypoints
    come from MediaPipe (``keypoint_source`` (N,) str, as ``keypoints.npz`` names them), zero
    elsewhere: OpenPose learned COCO's ears, marked on the auricle as the body model has them, and
    the truth's keypoints are the model's own. None when no frame needs them."""
    if not enabled or keypoint_source is None:
        return None
    mediapipe = torch.as_tensor([str(s) == "mediapipe" for s in keypoint_source])
    if not mediapipe.any():
        return None
    return detector_ear_offsets()[None] * mediapipe[:, None, None].float()


def face_point_visibility(keypoints3d: torch.Tensor, camera_position: torch.Tensor) -> torch.Tensor:
    """(B, 5) weight in [0, 1] of the nose, the left and right eye and the left and right ear:
    1 where the posed head turns the point towards the camera, 0 where it faces away.

    ``keypoints3d`` (B, K >= 5, 3) world keypoints in COCO order; ``camera_position`` (3,) the
    camera centre in world coordinates. The head's frame comes from the points themselves: its
    left from the right ear to the left, its front from the ears' midpoint to the nose. No
    gradient flows through the weights (they decide what counts, not where the head goes)."""
    kp = keypoints3d.detach()[:, :5]
    centre = 0.5 * (kp[:, LEFT_EAR] + kp[:, RIGHT_EAR])
    left = _unit(kp[:, LEFT_EAR] - kp[:, RIGHT_EAR])
    front = kp[:, NOSE] - centre
    front = _unit(front - (front * left).sum(-1, keepdim=True) * left)
    to_camera = _unit(camera_position.to(kp) - centre)
    c, s = math.cos(math.radians(EYE_SPREAD_DEG)), math.sin(math.radians(EYE_SPREAD_DEG))
    outward = torch.stack([front, c * front + s * left, c * front - s * left, left, -left], 1)  # (B, 5, 3)
    cos = (outward * to_camera[:, None]).sum(-1)
    return ((cos - HIDDEN_COS) / (SEEN_COS - HIDDEN_COS)).clamp(0.0, 1.0)


def trust_found_faces(keypoints: np.ndarray, landmarks: np.ndarray | None, weight: float) -> np.ndarray:
    """(N, K, 3) body ``keypoints`` with the nose's and the eyes' confidences times ``weight`` in
    the frames where the face landmarks (:func:`morf.fitting.inputs.project_landmarks`, (N, 49, 3),
    the five face anchors first) found no face.

    A pose detector reports a nose and two eyes on every head, a face turned three quarters away
    too, where the face mesh finds nothing; fitted, those guesses turn the head back towards the
    camera (the tennis clip's back-side views). Where a face mesh found a face in some frame of
    the capture and none in this one, the body's face points are the less likely to be seen. A
    capture whose face mesh found no face at all (faces too small for it, or no landmarks) keeps
    every confidence: it says nothing there. The ears keep theirs."""
    if landmarks is None or weight == 1.0:
        return keypoints
    found = landmarks[:, :5, 2].max(1) > 0
    if not found.any():
        return keypoints
    out = np.array(keypoints, copy=True)
    out[~found, NOSE:RIGHT_EYE + 1, 2] *= weight
    return out


def weight_face_points(detected: torch.Tensor, visibility: torch.Tensor) -> torch.Tensor:
    """``detected`` (B, K, 3) keypoints with the confidences of the five face points multiplied by
    ``visibility`` (B, 5) (:func:`face_point_visibility`)."""
    conf = torch.cat([detected[..., :5, 2] * visibility, detected[..., 5:, 2]], -1)
    return torch.cat([detected[..., :2], conf[..., None]], -1)


def _unit(v: torch.Tensor) -> torch.Tensor:
    return v / v.norm(dim=-1, keepdim=True).clamp_min(1e-9)
