"""The head's orientation, the wrists and the fingers fitted to face and hand landmarks.

The body fit sees 23 points: the nose, the eyes and the ears hold the head's orientation
loosely (a few pixels at a 40 px head are tens of degrees), and the wrist keypoint says nothing
of the hand's turn. Face anchors (pupils, nose tip, mouth, chin) and the 21 points of each hand
(:mod:`morf.capture.landmarks_face_hands`, MediaPipe or OpenPose alike) do; the body keypoints'
ears can join the face (they lie 8 cm behind it, so they fix the head's pitch and yaw better
than the face's flat points alone), with the caveat at ``HeadHandsConfig.ear_weight``. Their 3D
counterparts on the body model are fixed vertices and bone heads (:mod:`morf.body.parts`), the
ears the body model's own ear keypoints.

Two ways in:

* :func:`head_hands_term` is a loss term for any fit that poses the body: (B,) robust
  reprojection error of the landmark points, in the keypoint term's units.
* :func:`fit_head_hands` refines finished fits: it keeps every bone but the head, the wrists and
  the fingers, and fits those to the landmarks, frame by frame, with a pull toward the given
  head and wrist rotations and toward the fingers' rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from morf.body.model import BodyOutput, BodyPose
from morf.body.parts import HAND_CHAIN, face_anchor_vertices, hand_points
from morf.fitting.face_visibility import face_point_visibility
from morf.fitting.losses import geman_mcclure

# the neck lets the head move a little as well as turn: on a synthetic capture, fitted to the
# truth's own face and ear points (1.5 px noise), the head came to 5.6 degrees from the truth
# with it, 8.7 with the head alone
HEAD_BONES = ("neck01", "head")
WRIST_BONES = ("wrist.L", "wrist.R")
EARS = (4, 3)  # the right and the left ear among the body keypoints (COCO order)
NUM_FACE = 7  # the five face anchors and the two ears
NUM_POINTS = NUM_FACE + 42
GROUPS = ((0, NUM_FACE), (NUM_FACE, NUM_FACE + 21), (NUM_FACE + 21, NUM_POINTS))  # face, left hand, right hand


@dataclass(frozen=True)
class HeadHandsConfig:
    """Fields: face_weight, ear_weight, hand_weight: weights of the face anchors, the ears and the
    hand points (per point, times the point's confidence). The ears are off by default: with the
    synthetic truth's own points they took the head's error from 8.9 to 5.6 degrees, but
    MediaPipe's pose ears sit about 2 cm inside the body model's (COCO-regressed) ears, and with
    detected landmarks they made it worse (8.9 -> 10.0); profile_eye_visibility: a face counts only
    where the pose the step starts from turns both eyes at least this far towards the camera
    (:func:`hide_profile_faces`; 0, the default: every face the given pose turns towards it); sigma:
    Geman-McClure scale in units of 1 % of the image height;
    prior: weight of the squared change of the head and wrist rotations (radians^2);
    finger_prior: weight of the squared finger rotations (away from the rest, a relaxed hand);
    fingers: fit the 15 finger bones of each hand; steps, lr: Adam steps and step size
    (radians); batch: frames fitted together where no ``pair_weights`` link them (with them,
    every frame at once); min_points: confident points a hand (or the face) needs to be fitted at
    all;
    face_yaw_full, face_yaw_none: the face counts fully where the pose the step starts from
    turns the head at most ``face_yaw_full`` degrees from the camera, not at all from
    ``face_yaw_none`` degrees, linearly in between (:func:`face_yaw_weights`; ``face_yaw_none``
    180: every face counts fully). On People-Snapshot the step's turn of the head grew with that
    angle, 2 degrees under 30, 6 at 40-60, 13 at 60-70 and 22 at 70-80, always towards the
    camera (docs/fitting.md "The face mesh turned away");
    temporal: weight of the squared difference of neighbouring frames' changes (radians^2),
    times each pair's ``pair_weights`` (1 / gap^2 of the fit's temporal terms) and the two
    frames' head sizes in the image against ``REFERENCE_HEAD_SHARE`` (:func:`head_share`; the
    landmark term is in image pixels, so a small head pulls less): the change may not come and go
    from one frame to the next as a face is found and lost."""

    face_weight: float = 1.0
    profile_eye_visibility: float = 0.0
    ear_weight: float = 0.0
    hand_weight: float = 0.5
    sigma: float = 3.0
    prior: float = 2.0
    finger_prior: float = 2.0
    fingers: bool = True
    steps: int = 100
    lr: float = 0.02
    batch: int = 16
    min_points: int = 4
    face_yaw_full: float = 30.0
    face_yaw_none: float = 60.0
    temporal: float = 300.0


@dataclass(frozen=True)
class LandmarkIndex:
    """Where each landmark point comes from on the posed body: ``vertex_sets`` (5, 2) the face
    anchors' vertices (a one-vertex anchor repeats it), and per hand ``joints`` (2, 16) bone heads
    and ``tips`` (2, 5) vertices; ``joint_slots`` (16,) and ``tip_slots`` (5,) their places among
    the 21 hand points; ``head`` the head bone (the ears move with it)."""

    vertex_sets: torch.Tensor
    joints: torch.Tensor
    tips: torch.Tensor
    joint_slots: torch.Tensor
    tip_slots: torch.Tensor
    head: int


def landmark_index(model) -> LandmarkIndex:
    """The :class:`LandmarkIndex` of a body model (cached on it)."""
    cached = getattr(model, "_landmark_index", None)
    if cached is not None:
        return cached
    anchors = [tuple(a) * (2 // len(a)) for a in face_anchor_vertices(model)]
    hands = [hand_points(model, s) for s in ("L", "R")]
    idx = LandmarkIndex(torch.as_tensor(anchors, dtype=torch.long),
                        torch.as_tensor([h[0] for h in hands], dtype=torch.long),
                        torch.as_tensor([[v for _, v in h[1]] for h in hands], dtype=torch.long),
                        torch.as_tensor([k for k in range(21) if k % 4 != 0 or k == 0], dtype=torch.long),
                        torch.as_tensor([s for s, _ in hands[0][1]], dtype=torch.long), model.bone_index("head"))
    object.__setattr__(model, "_landmark_index", idx)
    return idx


def landmark_points3d(index: LandmarkIndex, out: BodyOutput) -> torch.Tensor:
    """(B, 7 + 42, 3) world positions of the face anchors, the right and the left ear, then the
    left and the right hand's 21 points, on a posed body."""
    B = out.vertices.shape[0]
    face = out.vertices[:, index.vertex_sets.reshape(-1)].reshape(B, -1, 2, 3).mean(2)
    face = torch.cat([face, out.keypoints3d[:, list(EARS)]], 1)
    hands = out.vertices.new_zeros(B, 2, 21, 3)
    hands[:, :, index.joint_slots] = out.joints[:, index.joints]
    hands[:, :, index.tip_slots] = out.vertices[:, index.tips]
    return torch.cat([face, hands.reshape(B, 42, 3)], 1)


class LandmarkPoser:
    """The landmark points of a posed body at a fixed shape, without skinning the whole mesh.

    A model with the Anny interface (``rest`` and ``bone_transforms``) has its shaped rest
    model computed once and only the dozen landmark vertices skinned per call (the refinement's
    inner loop; the ears, averages of thousands of head vertices, ride on the head bone's
    skinning matrix); any other :class:`~morf.body.model.BodyModel` goes through its full forward.
    """

    def __init__(self, model, shape: torch.Tensor):
        self.model, self.shape, self.index = model, shape, landmark_index(model)
        self.fast = hasattr(model, "rest") and hasattr(model, "bone_transforms")
        if self.fast:
            ids = torch.cat([self.index.vertex_sets.reshape(-1), self.index.tips.reshape(-1)])
            with torch.no_grad():
                rest = model.rest(shape)
            self.rest_bones = rest["rest_bone_poses"]
            self.rest_vertices = rest["rest_vertices"][:, ids]
            self.weights = model.dense_weights[ids]
            ears = model.keypoint_regressor[list(EARS)]  # (2, V)
            self.rest_ears = torch.einsum("kv,bvc->bkc", ears, rest["rest_vertices"])  # (S, 2, 3)

    def __call__(self, pose: BodyPose) -> torch.Tensor:
        """(B, 49, 3) :func:`landmark_points3d` of ``pose``."""
        if not self.fast:
            return landmark_points3d(self.index, self.model(pose, self.shape))
        from morf.body.lbs import linear_blend_skinning

        transforms, bone_poses = self.model.bone_transforms(pose, self.rest_bones)
        B = transforms.shape[0]
        rest = self.rest_vertices.expand(B, -1, -1) if self.rest_vertices.shape[0] == 1 else self.rest_vertices
        verts = linear_blend_skinning(rest, self.weights, transforms)
        nf = self.index.vertex_sets.numel()
        face = verts[:, :nf].reshape(B, -1, 2, 3).mean(2)
        head = transforms[:, self.index.head]  # (B, 4, 4)
        ears = torch.einsum("bij,bkj->bki", head[:, :3, :3], self.rest_ears.expand(B, -1, -1)) + head[:, None, :3, 3]
        face = torch.cat([face, ears], 1)
        hands = verts.new_zeros(B, 2, 21, 3)
        hands[:, :, self.index.joint_slots] = bone_poses[:, self.index.joints, :3, 3]
        hands[:, :, self.index.tip_slots] = verts[:, nf:].reshape(B, 2, 5, 3)
        return torch.cat([face, hands.reshape(B, 42, 3)], 1)


def landmark_targets(face_anchors: np.ndarray, hand_left: np.ndarray, hand_right: np.ndarray,
                     body: np.ndarray | None = None) -> np.ndarray:
    """(N, 49, 3) the evidence in :func:`landmark_points3d`'s order: (N, 5, 3) face anchors, the
    ears of the (N, 23, 3) body keypoints (confidence 0 without them), (N, 21, 3) left and right
    hand points (x, y pixels, confidence). Ears count only where the face was found too."""
    ears = np.zeros((face_anchors.shape[0], 2, 3), np.float32)
    if body is not None:
        ears = np.array(body[:, list(EARS)], np.float32)
        ears[..., 2] *= face_anchors[:, :, 2].min(1, keepdims=True) > 0
    return np.concatenate([face_anchors, ears, hand_left, hand_right], 1).astype(np.float32)


def head_hands_term(projected: torch.Tensor, targets: torch.Tensor, image_height: int,
                    cfg: HeadHandsConfig = HeadHandsConfig()) -> torch.Tensor:
    """(B,) the term: confidence-weighted Geman-McClure reprojection error of the 49 landmark
    points. ``projected`` (B, 49, 2) pixels (:func:`landmark_points3d` through the camera);
    ``targets`` (B, 49, 3) from :func:`landmark_targets`. A face or hand with fewer than
    ``cfg.min_points`` confident points counts nothing (one stray point would twist a hand)."""
    scale = image_height / 100
    r2 = ((projected - targets[..., :2]) / scale).pow(2).sum(-1)
    conf = targets[..., 2] * _usable(targets[..., 2], cfg.min_points)
    w = torch.cat([conf[:, :5] * cfg.face_weight, conf[:, 5:NUM_FACE] * cfg.ear_weight,
                   conf[:, NUM_FACE:] * cfg.hand_weight], 1)
    return (w * geman_mcclure(r2, cfg.sigma)).sum(-1)


def _usable(conf: torch.Tensor, min_points: int) -> torch.Tensor:
    """(B, 49) 1 where the point's group (face, left hand, right hand) has enough confident points."""
    out = torch.zeros_like(conf)
    for a, b in GROUPS:
        enough = ((conf[:, a:b] > 0.1).sum(1) >= min(min_points, b - a)).to(conf.dtype)
        out[:, a:b] = enough[:, None]
    return out


def hide_turned_away_faces(targets: torch.Tensor, points3d: torch.Tensor, camera, margin: float = 0.02) -> torch.Tensor:
    """``targets`` (B, 49, 3) with the face group's confidences zeroed in frames where the posed
    body ``points3d`` (B, 49, 3) turns its face away: the nose tip not at least ``margin`` metres
    nearer the camera than the ears' midpoint. A face detector finds faces on the back of a head
    (hair with two dark patches); fitting to those turns the head round."""
    z = camera.world_to_camera(points3d)[..., 2]  # depth along the optical axis
    facing = z[:, 2] < z[:, 5:7].mean(1) - margin
    out = targets.clone()
    out[:, :NUM_FACE, 2] = out[:, :NUM_FACE, 2] * facing[:, None].to(out.dtype)
    return out


def hide_profile_faces(targets: torch.Tensor, points3d: torch.Tensor, camera, min_visibility: float) -> torch.Tensor:
    """``targets`` (B, 49, 3) with the face group's confidences zeroed in frames where the posed
    body ``points3d`` (B, 49, 3) turns an eye away from the camera (its
    :func:`~morf.fitting.face_visibility.face_point_visibility` under ``min_visibility``): a profile.

    The face mesh places every point of a face, the far eye too; in a profile it draws a face
    turned about 50 degrees where the head is turned 85 (People-Snapshot: the eyes 9 px apart
    against 15 px in the front views), and the head turned to it faced the camera. There the body
    keypoints' face points, weighted by what the pose shows, hold the head instead."""
    coco = points3d[:, [2, 1, 0, 6, 5]]  # nose, left eye, right eye, left ear, right ear
    position = torch.as_tensor(camera.position, dtype=points3d.dtype)
    eyes = face_point_visibility(coco, position)[:, 1:3]
    frontal = (eyes >= min_visibility).all(1)
    out = targets.clone()
    out[:, :NUM_FACE, 2] = out[:, :NUM_FACE, 2] * frontal[:, None].to(out.dtype)
    return out


def head_yaw_deg(points3d: torch.Tensor, camera) -> torch.Tensor:
    """(B,) degrees between where the posed head ``points3d`` (B, 49, 3) faces (from the ears'
    midpoint through the nose tip) and the direction from its nose tip to the camera: 0 facing
    it, 90 a profile, 180 the back of the head."""
    position = torch.as_tensor(camera.position, dtype=points3d.dtype)
    forward = points3d[:, 2] - points3d[:, 5:7].mean(1)
    to_camera = position - points3d[:, 2]
    cos = torch.nn.functional.cosine_similarity(forward, to_camera, dim=-1)
    return torch.rad2deg(torch.arccos(cos.clamp(-1.0, 1.0)))


def face_yaw_weights(targets: torch.Tensor, points3d: torch.Tensor, camera, full: float, none: float) -> torch.Tensor:
    """``targets`` (B, 49, 3) with the face group's confidences scaled by how squarely the posed
    body ``points3d`` faces the camera: 1 up to ``full`` degrees (:func:`head_yaw_deg`), 0 from
    ``none``, linear between; unchanged where ``none`` is 180 or more.

    The face mesh guesses the far side of a turned face: the further the head turns, the less
    turned it draws the face, and a head turned to it turns towards the camera."""
    if none >= 180:
        return targets
    w = ((none - head_yaw_deg(points3d, camera)) / max(none - full, 1e-6)).clamp(0.0, 1.0)
    out = targets.clone()
    out[:, :NUM_FACE, 2] = out[:, :NUM_FACE, 2] * w[:, None].to(out.dtype)
    return out


HEAD_SIZE_M = 0.2  # a head's height, for its size in the image
# the image share (percent of its height) of a HEAD_SIZE_M head at which ``temporal`` applies as
# given (the default synthetic capture's head: 10.6 %); elsewhere it scales with the size squared
REFERENCE_HEAD_SHARE = 10.0


def head_share(points3d: torch.Tensor, camera) -> torch.Tensor:
    """(B,) a ``HEAD_SIZE_M`` head at the ears' midpoint of ``points3d`` (B, 49, 3), in percent of
    the image height: the scale of the landmark term's pixels against a turn of the head."""
    z = camera.world_to_camera(points3d[:, 5:7].mean(1, keepdim=True))[:, 0, 2].clamp_min(1e-3)
    return 100.0 * float(camera.fy) * HEAD_SIZE_M / z / camera.height


def fitted_bones(model, fingers: bool) -> tuple[list[int], list[int]]:
    """(neck, head and wrist bone indices; finger bone indices): what the refinement moves."""
    main = [model.bone_index(b) for b in HEAD_BONES + WRIST_BONES]
    hand = [model.bone_index(f"{b}.{s}") for s in ("L", "R") for b in HAND_CHAIN] if fingers else []
    return main, hand


@dataclass(frozen=True)
class HeadHandsFit:
    """Fields: rotvecs (N, J, 3) the refined poses (other bones as given); residual_before,
    residual_after: (N, 3) mean pixel distance of the confident face, left-hand and right-hand
    points to their landmarks (NaN where a group has too few)."""

    rotvecs: np.ndarray
    residual_before: np.ndarray
    residual_after: np.ndarray


def landmark_residual_px(projected: torch.Tensor, targets: torch.Tensor, min_points: int) -> torch.Tensor:
    """(B, 3) mean pixel distance per group (the five face anchors, left hand, right hand), NaN
    where the group has too few confident points."""
    d = (projected - targets[..., :2]).norm(dim=-1)
    w = (targets[..., 2] > 0.1).to(d.dtype) * _usable(targets[..., 2], min_points)
    out = []
    for a, b in ((0, 5),) + GROUPS[1:]:
        n = w[:, a:b].sum(1)
        mean = (w[:, a:b] * d[:, a:b]).sum(1) / n.clamp_min(1)
        out.append(torch.where(n > 0, mean, torch.full_like(n, float("nan"))))
    return torch.stack(out, 1)


def _refine_bones(rot0: torch.Tensor, tr: torch.Tensor, tgt: torch.Tensor, poser: LandmarkPoser, camera,
                  bones: torch.Tensor, prior: float, toward_rest: bool, cfg: HeadHandsConfig,
                  pair_weights: torch.Tensor | None = None):
    """Adam on ``bones``' rotvecs of ``rot0`` (B, J, 3) against the landmarks; the prior pulls
    the change (or, ``toward_rest``, the rotation itself) toward zero; ``pair_weights`` (B-1,)
    (or None) tie neighbouring frames' changes together (``cfg.temporal``). Returns (rotvecs, pixels)."""
    delta = torch.zeros(rot0.shape[0], len(bones), 3, requires_grad=True)
    opt = torch.optim.Adam([delta], lr=cfg.lr)
    for _ in range(cfg.steps):
        r = rot0.index_add(1, bones, delta)
        px = camera.project(poser(BodyPose(r, tr)))
        held = r[:, bones] if toward_rest else delta
        loss = head_hands_term(px, tgt, camera.height, cfg).sum() + prior * held.pow(2).sum()
        if pair_weights is not None:
            step = (delta[1:] - delta[:-1]).pow(2).sum((1, 2))
            loss = loss + cfg.temporal * (pair_weights * step).sum()
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        r = rot0.index_add(1, bones, delta)
        return r, camera.project(poser(BodyPose(r, tr)))


def fit_head_hands(model, rotvecs: np.ndarray, transl: np.ndarray, shape: np.ndarray, camera, targets: np.ndarray,
                   cfg: HeadHandsConfig = HeadHandsConfig(), pair_weights: np.ndarray | None = None) -> HeadHandsFit:
    """Refine the head, the wrists (and with ``cfg.fingers`` the fingers) of finished fits to the
    landmarks ``targets`` (N, 49, 3) (:func:`landmark_targets`); every other bone, the root and
    the translation stay as given. ``shape`` (1 or N, S); ``camera`` a PinholeCamera in the
    landmarks' pixels. Faces found where the given pose turns the head away are ignored
    (:func:`hide_turned_away_faces`), and faces count less the further it turns the head from
    the camera (:func:`face_yaw_weights`). Frames without evidence come back unchanged, unless
    ``pair_weights`` (N-1,) (:meth:`~morf.fitting.frame_spacing.FrameSpacing.temporal_weights`)
    tie the head's and the wrists' changes to their neighbours' (``cfg.temporal``); then all
    frames are fitted at once.

    The head and the wrists are fitted first, then the fingers with them held: fitted together,
    the fingers soaked up the wrists' turn (wrist error on a synthetic capture 11-12 degrees
    alone, 13-15 with the fingers)."""
    main, fingers = (torch.as_tensor(b, dtype=torch.long) for b in fitted_bones(model, cfg.fingers))
    rot_all = torch.as_tensor(np.asarray(rotvecs, np.float32))
    out_rot = rot_all.clone()
    tr_all = torch.as_tensor(np.asarray(transl, np.float32))
    shape_t = torch.as_tensor(np.asarray(shape, np.float32)).reshape(-1, np.asarray(shape).shape[-1])
    tgt_all = torch.as_tensor(np.asarray(targets, np.float32))
    N = rot_all.shape[0]
    before, after = torch.full((N, 3), float("nan")), torch.full((N, 3), float("nan"))
    linked = pair_weights is not None and cfg.temporal > 0 and N > 1
    batch = N if linked else cfg.batch
    for s in range(0, N, batch):
        sl = slice(s, min(s + batch, N))
        rot, tr = rot_all[sl], tr_all[sl]
        poser = LandmarkPoser(model, shape_t if shape_t.shape[0] == 1 else shape_t[sl])
        with torch.no_grad():
            points = poser(BodyPose(rot, tr))
            tgt = hide_turned_away_faces(tgt_all[sl], points, camera)
            if cfg.profile_eye_visibility > 0:
                tgt = hide_profile_faces(tgt, points, camera, cfg.profile_eye_visibility)
            tgt = face_yaw_weights(tgt, points, camera, cfg.face_yaw_full, cfg.face_yaw_none)
            before[sl] = landmark_residual_px(camera.project(points), tgt, cfg.min_points)
        pairs = None
        if linked:  # the landmark term's pull scales with the head's size in the image: the tie too
            share = head_share(points, camera) / REFERENCE_HEAD_SHARE
            pairs = torch.as_tensor(np.asarray(pair_weights, np.float32)) * share[1:] * share[:-1]
        rot, px = _refine_bones(rot, tr, tgt, poser, camera, main, cfg.prior, False, cfg, pairs)
        if len(fingers):
            rot, px = _refine_bones(rot, tr, tgt, poser, camera, fingers, cfg.finger_prior, True, cfg)
        after[sl] = landmark_residual_px(px, tgt, cfg.min_points)
        out_rot[sl] = rot
    return HeadHandsFit(out_rot.numpy(), before.numpy(), after.numpy())
