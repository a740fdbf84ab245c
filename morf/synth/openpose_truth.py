"""A synthetic capture's frames as another tool would hand them over: image files plus OpenPose
JSON (BODY_25 with the 70 face and 2 x 21 hand points), written from the ground truth plus noise.

This is how a user arrives with a photo set made elsewhere (``morf ingest P --frames DIR
--keypoints DIR``), so the real import path (file pairing, OpenPose's pixel convention, the person
follower, mask segmentation) runs on data whose truth is known.

What OpenPose does that is kept: pixel centres on integers; confidences below 1; a back view
without face (nose, eyes and the 70 face points at 0, the ears seen); hands reported whenever the
wrist is in the frame. Left and right are labelled correctly (OpenPose's own mistakes are not
imitated).

Where the points sit on the body model: body points are Anny's COCO keypoints (neck and mid-hip
are midpoints, as OpenPose defines them); hand points are the wrist and finger bone heads and the
finger tips; face points are vertices of the face's front surface under a template of the
68-point layout (plus the two pupils) scaled to the model's eyes, nose, mouth and chin. The points
the fit reads as face anchors (the nose tip, the inner lips' middles, the chin, the pupils) are the
body model's own anchor vertices (:func:`morf.body.parts.face_anchor_vertices`): the truth says
where the fit's points are, so an error measured against it is the fit's.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.body.parts import face_anchor_vertices
from morf.camera import PinholeCamera
from morf.capture.keypoint_layout import BODY25_TO_OURS

FINGERS = ("finger1", "finger2", "finger3", "finger4", "finger5")  # thumb ... little finger
FACE_AWAY_COS = 0.1  # a face turned further than this from the camera is not found


@dataclass(frozen=True)
class LandmarkPoints:
    """Where the face and hand points sit on the body model.

    Fields:
        face_vertices: (70,) vertex index per face point (OpenPose face order).
        hand_joints: {"L", "R"}: (16,) bone indices whose heads are hand points 0, 1-3, 5-7, ...
        hand_tips: {"L", "R"}: (5,) vertex index of each finger tip (hand points 4, 8, 12, 16, 20).
    """

    face_vertices: np.ndarray
    hand_joints: dict
    hand_tips: dict


def _face_template(z_nose: float, z_mouth: float, z_chin: float) -> np.ndarray:
    """(70, 2) x (the person's left +), z (up) of the 68-point face layout and the pupils, in units
    of the distance between the pupils, origin between them."""
    pts = []
    for k in range(17):  # jaw, from the person's right ear over the chin to the left
        t = np.pi * k / 16
        pts.append((-1.0 * np.cos(t), -0.15 + (z_chin + 0.15) * np.sin(t)))
    for side in (-1, 1):  # brows, outer to inner on the right, inner to outer on the left
        xs = np.linspace(-0.9, -0.2, 5) if side < 0 else np.linspace(0.2, 0.9, 5)
        pts += [(x, 0.33 + 0.08 * np.sin(np.pi * (abs(x) - 0.2) / 0.7)) for x in xs]
    pts += [(0.0, z) for z in np.linspace(0.1, z_nose, 4)]  # nose bridge to tip
    pts += [(x, z_nose - 0.12 + 0.04 * abs(x) / 0.25) for x in np.linspace(-0.25, 0.25, 5)]  # nostrils
    for cx, order in ((-0.5, (np.pi, 2 * np.pi / 3, np.pi / 3, 0.0, -np.pi / 3, -2 * np.pi / 3)),
                      (0.5, (np.pi, 2 * np.pi / 3, np.pi / 3, 0.0, -np.pi / 3, -2 * np.pi / 3))):
        pts += [(cx + 0.22 * np.cos(a), 0.08 * np.sin(a)) for a in order]  # eye contour
    outer = [np.pi - k * np.pi / 6 for k in range(7)] + [-np.pi / 6 * k for k in range(1, 6)]
    pts += [(0.4 * np.cos(a), z_mouth + 0.16 * np.sin(a)) for a in outer]
    inner = [np.pi, 2 * np.pi / 3, np.pi / 2, np.pi / 3, 0.0, -np.pi / 3, -np.pi / 2, -2 * np.pi / 3]
    pts += [(0.28 * np.cos(a), z_mouth + 0.05 * np.sin(a)) for a in inner]
    pts += [(-0.5, 0.0), (0.5, 0.0)]  # pupils
    return np.asarray(pts, np.float64)


def landmark_points(model) -> LandmarkPoints:
    """Find the face and hand points on ``model`` (Anny: faces -Y, +X the person's left) in its
    rest pose at the default shape."""
    with torch.no_grad():
        out = model(model.zero_pose(1), model.default_shape())
    v, J = out.vertices[0].cpu().numpy(), out.joints[0].cpu().numpy()
    dominant = model.dense_weights.argmax(1).cpu().numpy()
    head = dominant == model.bone_index("head")  # Anny's face has no bones of its own but the eyes
    eye_ids = [np.nonzero(dominant == model.bone_index(f"eye.{s}"))[0] for s in ("R", "L")]
    pupils = [int(ids[np.argmin(v[ids, 1])]) for ids in eye_ids]
    centre = 0.5 * (v[pupils[0]] + v[pupils[1]])
    d = float(np.linalg.norm(v[pupils[1]] - v[pupils[0]]))
    mid = head & (np.abs(v[:, 0] - centre[0]) < 0.004)
    nose = np.nonzero(mid)[0][np.argmin(v[mid, 1])]
    near = np.nonzero(mid & (v[:, 1] < v[nose, 1] + 0.03))[0]
    chin = near[np.argmin(v[near, 2])]
    z_nose, z_chin = (v[nose, 2] - centre[2]) / d, (v[chin, 2] - centre[2]) / d
    template = _face_template(z_nose, 0.45 * z_nose + 0.55 * z_chin, z_chin)
    ids = np.nonzero(head)[0]
    face = np.zeros(70, np.int64)
    for k, (x, z) in enumerate(template):
        if k >= 68:
            face[k] = pupils[k - 68]
            continue
        dist2 = (v[ids, 0] - (centre[0] + x * d)) ** 2 + (v[ids, 2] - (centre[2] + z * d)) ** 2
        close = ids[dist2 < (0.004 + dist2.min() ** 0.5) ** 2]
        face[k] = close[np.argmin(v[close, 1])]  # the front-most of the vertices under the point
    right_eye, left_eye, (nose_tip,), (upper_lip, lower_lip), (chin_v,) = face_anchor_vertices(model)
    face[[8, 30, 62, 66, 68, 69]] = [chin_v, nose_tip, upper_lip, lower_lip, right_eye[0], left_eye[0]]
    for first, ids, (pupil,) in ((36, eye_ids[0], right_eye), (42, eye_ids[1], left_eye)):
        face[first:first + 6] = _eye_ring(v, ids, pupil)
    joints, tips = {}, {}
    for s in ("L", "R"):
        joints[s] = np.array([model.bone_index(f"wrist.{s}")]
                             + [model.bone_index(f"{f}-{k}.{s}") for f in FINGERS for k in (1, 2, 3)])
        tip = []
        for f in FINGERS:
            last = model.bone_index(f"{f}-3.{s}")
            on = np.nonzero(dominant == last)[0]
            tip.append(int(on[np.argmax(np.linalg.norm(v[on] - J[last], axis=1))]))
        tips[s] = np.array(tip)
    return LandmarkPoints(face, joints, tips)


def _eye_ring(v: np.ndarray, ids: np.ndarray, pupil: int) -> np.ndarray:
    """(6,) eyeball vertices around the pupil in the 68-point eye order (the corner on the person's
    right, two upper, the other corner, two lower: outer first for the right eye, inner first for
    the left), 8 mm to either side and 4 mm up and down: the eye contour whose mean the fit reads
    as the eye sits on the pupil (an eyelid contour would sit a centimetre in front of it)."""
    front = ids[v[ids, 1] < v[pupil, 1] + 0.006]
    angles = (np.pi, 2 * np.pi / 3, np.pi / 3, 0.0, -np.pi / 3, -2 * np.pi / 3)
    out = []
    for a in angles:
        target = v[pupil, [0, 2]] + np.array([0.008 * np.cos(a), 0.004 * np.sin(a)])
        out.append(front[np.argmin(((v[front][:, [0, 2]] - target) ** 2).sum(1))])
    return np.array(out)


def _hand(joints: np.ndarray, verts: np.ndarray, lm: LandmarkPoints, side: str) -> np.ndarray:
    """(21, 3) world points of one hand in OpenPose order (wrist, then each finger base to tip)."""
    j = joints[lm.hand_joints[side]]
    out = [j[0]]
    for f in range(5):
        out += [j[1 + 3 * f], j[2 + 3 * f], j[3 + 3 * f], verts[lm.hand_tips[side][f]]]
    return np.stack(out)


def _visible_conf(n: int, rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(0.55, 0.92, n)


def _to_openpose(points: np.ndarray, conf: np.ndarray, noise_px: float, rng: np.random.Generator,
                 camera: PinholeCamera) -> list[float]:
    """(K, 2) MoRF pixels + (K,) confidences -> OpenPose's flat [x, y, c, ...] (pixel centres on
    integers; an unseen point, or one outside the frame, is 0, 0, 0)."""
    xy = points + rng.normal(0.0, noise_px, points.shape) - 0.5
    inside = (xy[:, 0] >= 0) & (xy[:, 0] < camera.width) & (xy[:, 1] >= 0) & (xy[:, 1] < camera.height)
    c = np.where(inside, conf, 0.0)
    out = np.where(c[:, None] > 0, np.concatenate([xy, c[:, None]], 1), 0.0)
    return [round(float(x), 3) for x in out.reshape(-1)]


def face_toward_camera(verts: np.ndarray, lm: LandmarkPoints, camera: PinholeCamera) -> float:
    """Cosine between the face's forward direction (the normal of the plane through the pupils and
    the chin) and the direction from the nose tip to the camera, from (V, 3) posed vertices."""
    f = verts[lm.face_vertices]
    right_eye, left_eye, chin = f[68], f[69], f[8]
    across, down = left_eye - right_eye, chin - 0.5 * (left_eye + right_eye)
    forward = np.cross(down, across)  # with +X left and Z up: (-Z) x (+X) = -Y, the face's forward
    forward /= max(np.linalg.norm(forward), 1e-9)
    centre = -np.asarray(camera.R).T @ np.asarray(camera.t)
    to_cam = centre - f[30]
    return float(forward @ (to_cam / max(np.linalg.norm(to_cam), 1e-9)))


def openpose_person(kp3d: np.ndarray, joints: np.ndarray, verts: np.ndarray, lm: LandmarkPoints,
                    camera: PinholeCamera, rng: np.random.Generator, noise_px: float,
                    landmark_noise_px: float) -> dict:
    """One frame's person as OpenPose writes it: BODY_25, face and both hands."""
    def px(p):
        return camera.project(torch.as_tensor(np.asarray(p, np.float64))).numpy()

    ours = px(kp3d)  # (23, 2)
    body = np.zeros((25, 2))
    conf = _visible_conf(25, rng)
    for src, dst in BODY25_TO_OURS.items():
        body[src] = ours[dst]
    body[1] = 0.5 * (ours[5] + ours[6])  # neck: OpenPose's is between the shoulders
    body[8] = 0.5 * (ours[11] + ours[12])  # mid-hip
    facing = face_toward_camera(verts, lm, camera)
    if facing < FACE_AWAY_COS:  # the back of the head: no nose, no eyes, no face
        conf[[0, 15, 16]] = 0.0
    face_conf = _visible_conf(70, rng) if facing >= FACE_AWAY_COS else np.zeros(70)
    person = {"person_id": [-1], "pose_keypoints_2d": _to_openpose(body, conf, noise_px, rng, camera),
              "face_keypoints_2d": _to_openpose(px(verts[lm.face_vertices]), face_conf, landmark_noise_px, rng,
                                                camera)}
    for side, key in (("L", "hand_left_keypoints_2d"), ("R", "hand_right_keypoints_2d")):
        person[key] = _to_openpose(px(_hand(joints, verts, lm, side)), _visible_conf(21, rng), landmark_noise_px,
                                   rng, camera)
    return person


def write_openpose_views(project, out_dir: str | Path, model, *, noise_px: float = 3.0,
                         landmark_noise_px: float = 2.0, seed: int = 0, image_ext: str = ".jpg") -> list[Path]:
    """Write every frame of the synthetic ``project`` (a CaptureProject with ground truth) to
    ``out_dir`` as ``view_000.jpg`` + ``view_000_keypoints.json``; returns the image paths.

    The images are the project's frames (a photo set's JPEGs at quality 95); the keypoints come
    from the true poses and shape, with Gaussian noise of ``noise_px`` (body) and
    ``landmark_noise_px`` (face, hands) pixels."""
    from morf.io import write_image
    from morf.synth.ground_truth import load_ground_truth

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    gt = load_ground_truth(project)
    camera = project.camera()
    lm = landmark_points(model)
    rng = np.random.default_rng(seed)
    shape = torch.as_tensor(gt.shape, dtype=torch.float32).reshape(1, -1)
    paths = []
    for i in range(project.num_frames):
        pose = BodyPose(torch.as_tensor(gt.rotvecs[i:i + 1], dtype=torch.float32),
                        torch.as_tensor(gt.transl[i:i + 1], dtype=torch.float32))
        with torch.no_grad():
            out = model(pose, shape)
        person = openpose_person(out.keypoints3d[0].numpy(), out.joints[0].numpy(), out.vertices[0].numpy(), lm,
                                 camera, rng, noise_px, landmark_noise_px)
        name = f"view_{i:03d}"
        path = out_dir / f"{name}{image_ext}"
        write_image(path, project.load_frame(i), jpeg_quality=95)
        (out_dir / f"{name}_keypoints.json").write_text(json.dumps({"version": 1.3, "people": [person]}))
        paths.append(path)
    return paths
