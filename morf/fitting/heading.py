"""Which way a body faces: front or back, when the keypoints' left and right cannot say.

Seen from the back, a body is the mirror image of the same body seen from the front with left and
right swapped. Under a distant camera the two project to the same torso keypoints and the same
silhouette (heading ``h`` and ``180 - h`` with the labels exchanged explain them equally). Which
one it is rests on the detector's left/right labels, and a detector that takes a back view for a
front view swaps them: the rigid first stage then fits a body facing the camera to a person
facing away, and every later stage inherits it (arms crossed behind the back, knees bending
backwards).

So the first stage also tries every heading with the labels exchanged, and picks among all of
them with evidence that is not mirror-symmetric:

* **the face**: a body facing the camera shows it. Nose and eyes missing while the torso is seen
  (OpenPose's answer to the back of a head) cost every hypothesis that faces the camera;
  confident face points cost a hypothesis facing away a little (detectors such as MediaPipe
  report a face on a back view too, so this is weak evidence);
* **the labels**: exchanging them costs something, so that without a face to say otherwise the
  detector's own labels win.

A frame fitted with its labels exchanged keeps them exchanged for the rest of the fit
(:func:`exchange_labels`); ``BodyFits.label_swapped`` records which.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.capture.keypoint_layout import MIRROR_INDEX
from morf.camera import PinholeCamera

NOSE, EYES = 0, (1, 2)
SHOULDERS, HIPS = (5, 6), (11, 12)
FACE_SEEN_CONF = 0.3  # a face point counts as seen above this confidence
# cosine between the body's forward direction and the direction to the camera above which the body
# faces the camera fully (45 degrees), and below whose negative it faces away fully
FACING_FULL = 0.7


@dataclass(frozen=True)
class HeadingEvidence:
    """Costs of the front/back choice, added to each hypothesis' mean robust keypoint loss, in
    units of that loss's saturation (1: every keypoint missed by far; a body facing the wrong way
    with the right labels scores about 0.5).

    Fields:
        swap: exchanging the detector's left and right labels.
        face_missing: a body facing the camera whose nose and eyes are not seen.
        face_away: a body facing away whose nose and eyes are seen confidently.
    """

    swap: float = 0.1
    face_missing: float = 0.3
    face_away: float = 0.03


def exchange_labels(points: np.ndarray, swapped: np.ndarray | None, mirror: np.ndarray = MIRROR_INDEX) -> np.ndarray:
    """(N, P, 3) points with left and right exchanged in the frames where ``swapped`` (N,) is set:
    point ``k`` of such a frame becomes point ``mirror[k]`` (P,). The default is the 23 body
    keypoints' table; the face and hand landmarks pass their own
    (:func:`morf.fitting.landmark_refinement.exchange_landmark_labels`). ``points`` itself comes
    back when no frame is swapped."""
    if swapped is None or not np.any(swapped):
        return points
    out = np.array(points, copy=True)
    out[swapped] = out[swapped][:, mirror]
    return out


def face_seen(points: np.ndarray, min_conf: float = FACE_SEEN_CONF) -> np.ndarray:
    """(N,) share of nose and eyes seen, in frames whose shoulders and hips are seen (there the
    face's absence means something); NaN elsewhere."""
    torso = (points[:, list(SHOULDERS + HIPS), 2] > min_conf).all(1)
    seen = (points[:, [NOSE, *EYES], 2] > min_conf).mean(1)
    return np.where(torso, seen, np.nan)


def facing(R: torch.Tensor, transl: torch.Tensor, camera: PinholeCamera) -> torch.Tensor:
    """(...,) cosine between each body's forward direction (its -Y axis) and the direction from
    the body to the camera's centre. R: (..., 3, 3) body-to-world; transl: (..., 3)."""
    Rc = torch.as_tensor(camera.R, dtype=R.dtype)
    centre = -Rc.T @ torch.as_tensor(camera.t, dtype=R.dtype)
    to_cam = centre - transl
    to_cam = to_cam / to_cam.norm(dim=-1, keepdim=True).clamp_min(1e-9)
    forward = -R[..., :, 1]
    return (forward * to_cam).sum(-1)


def heading_costs(cos_facing: torch.Tensor, seen: np.ndarray, swapped: torch.Tensor,
                  evidence: HeadingEvidence) -> torch.Tensor:
    """(N, K) cost of each hypothesis beyond its keypoint fit (units: see :class:`HeadingEvidence`).

    Args:
        cos_facing: (N, K) :func:`facing` of each hypothesis; seen: (N,) :func:`face_seen`;
        swapped: (K,) bool, the hypothesis reads the labels exchanged.
    """
    s = torch.as_tensor(np.nan_to_num(seen, nan=-1.0), dtype=cos_facing.dtype)[:, None]
    known = s >= 0
    toward = (cos_facing / FACING_FULL).clamp(0, 1)
    away = (-cos_facing / FACING_FULL).clamp(0, 1)
    cost = evidence.swap * swapped.to(cos_facing.dtype)[None].expand_as(cos_facing)
    face = evidence.face_missing * toward * (1 - s) + evidence.face_away * away * s
    return cost + torch.where(known, face, torch.zeros_like(face))
