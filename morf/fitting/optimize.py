"""Stages 2 and 3 of the fit: body pose, then everything, batched over all frames.

Every step evaluates all frames (in chunks of ``chunk_frames`` whose gradients are accumulated,
so memory stays bounded for long videos) and takes one Adam step. Per-frame data terms
(keypoints, silhouette) are summed over frames; sequence terms (pose prior, temporal, shape)
are computed on the whole parameter tensors.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from morf.camera import PinholeCamera, project_points
from morf.fitting.adam import Adam
from morf.fitting.config import FitConfig, StageConfig
from morf.fitting.evaluate import silhouettes
from morf.fitting.face_visibility import detector_ears, face_point_visibility, weight_face_points
from morf.fitting.fit_body import FitBody
from morf.fitting.inputs import FitInputs
from morf.fitting.losses import (dice_loss_per_frame, keypoint_loss, rotation_acceleration_loss, rotation_temporal_loss,
                                 shape_loss, temporal_loss)
from morf.fitting.offsets import smoothness_loss
from morf.fitting.params import FIT_BONES, FitParameters
from morf.fitting.pose_prior import JointLimitPrior
from morf.fitting.twist import twist_penalty
from morf.pipeline.control import Progress, StageControl
from morf.progress import progress
from morf.raster.soft_silhouette import front_facing, soft_silhouette


HEAD_CHAIN = tuple(FIT_BONES.index(b) for b in ("neck01", "head"))  # rows of FitParameters.body


@dataclass
class FitProblem:
    """Everything a stage needs besides its own settings (built once per fit)."""

    body: FitBody
    prior: JointLimitPrior
    inputs: FitInputs
    keypoints: torch.Tensor  # (N, 23, 3) detections as a tensor
    masks: torch.Tensor | None  # (N, h, w) soft person masks at the silhouette raster
    sil_camera: PinholeCamera | None  # the camera scaled to the silhouette raster
    shape_mean: torch.Tensor  # (1, S) prior mean of the shape
    offset_edges: torch.Tensor | None  # (E, 2) edges of the proxy mesh (offset smoothness), or None
    keypoint_scale: float  # pixels per keypoint residual unit (1% of the image height)
    pair_weights: torch.Tensor | None = None  # (N-1,) temporal weight factor per neighbour pair (frame_spacing.py)
    camera_position: torch.Tensor | None = None  # (3,) the camera centre, world (which face points it sees)
    face_weights: torch.Tensor | None = None  # (N, 5) the stage's weights of the face points (face_visibility.py)
    ear_offsets: torch.Tensor | None = None  # (N, 2, 3) where each frame's detector marks the ears (face_visibility.py)
    guessed: torch.Tensor | None = None  # (N,) bool frames whose keypoints a detector guessed (None: all)


def _data_terms(problem: FitProblem, params: FitParameters, cfg: FitConfig, idx: torch.Tensor,
                sil_idx: torch.Tensor | None, sil_factor: float,
                offsets: bool = False) -> tuple[torch.Tensor, dict[str, float]]:
    """Keypoint (+ silhouette) loss of the frames ``idx`` (a chunk)."""
    use_sil = sil_idx is not None and sil_idx.numel() > 0
    local = torch.searchsorted(idx, sil_idx.contiguous()) if use_sil else idx.new_zeros(0)
    out = problem.body(params.pose_matrices(idx), params.shape(idx), proxy_rows=local,
                       proxy_offsets=params.offsets if (offsets and use_sil) else None)
    cam = problem.inputs.camera
    kp3d = _detector_keypoints(problem, out, idx)
    proj = cam.project(kp3d)
    detected = problem.keypoints[idx]
    if problem.face_weights is not None:  # a detector's guesses at the face points the head turns away
        detected = weight_face_points(detected, problem.face_weights[idx])
    kp = keypoint_loss(proj, detected, problem.keypoint_scale, cfg.keypoint_robust_sigma).sum()
    total = cfg.keypoint_weight * kp
    logs = {"keypoints": float(kp.detach())}
    if cfg.twist_weight > 0:  # an anatomically possible body: the pelvis turns with the shoulders
        twist = twist_penalty(kp3d, cfg.twist_limit_deg).sum()
        total = total + cfg.twist_weight * twist
        logs["twist"] = float(twist.detach())
    if use_sil:
        cam_v = problem.sil_camera.world_to_camera(out.proxy_vertices)
        sc = problem.sil_camera
        pix = project_points(cam_v, sc.fx, sc.fy, sc.cx, sc.cy)
        faces = problem.body.proxy_faces
        h, w = problem.masks.shape[-2:]
        covered = None
        if pix.device.type == "cpu":  # the GL rasterizer finds the covered pixels (torch without GL)
            covered = torch.from_numpy(silhouettes(out.proxy_vertices.detach(), faces, sc, 1.0, w, h, front_only=True))
        sil = soft_silhouette(pix, faces, h, w, sigma=cfg.silhouette_sigma,
                              face_mask=front_facing(cam_v.detach(), faces), covered=covered)
        dice = dice_loss_per_frame(sil, problem.masks[sil_idx]).sum() * sil_factor
        total = total + cfg.silhouette_weight * dice
        logs["silhouette"] = float(dice.detach())
    return total, logs


def _sequence_terms(problem: FitProblem, params: FitParameters, cfg: FitConfig, stage: StageConfig,
                    offsets: bool = False):
    total = params.transl.new_zeros(())
    logs = {}
    if offsets:
        smooth = smoothness_loss(params.offsets, problem.offset_edges)
        total = total + cfg.offset_smooth_weight * smooth + cfg.offset_l2_weight * params.offsets.pow(2).sum()
        logs["offset_mm"] = float(params.offsets.detach().mean()) * 1000 * params.num_frames
    if stage.body_pose:
        prior = problem.prior(params.body).sum()
        l2 = params.body.pow(2).sum()
        total = total + cfg.pose_prior_weight * prior + cfg.pose_l2_weight * l2
        head = head_prior_weights(problem.face_weights, cfg, params.num_frames).to(params.body)
        total = total + (head[:, None, None] * params.body[:, list(HEAD_CHAIN)].pow(2)).sum()
        logs["prior"] = float(prior.detach())
    if stage.shape:
        sh = shape_loss(params.shape(), problem.shape_mean).sum()
        total = total + cfg.shape_weight * sh
        logs["shape"] = float(sh.detach())
    if cfg.temporal and params.num_frames > 1:
        w = problem.pair_weights
        tr = temporal_loss(params.transl, w).sum()
        R = params.root_matrix()
        if cfg.root_smoothing == "acceleration":
            root = cfg.root_acceleration_weight * rotation_acceleration_loss(R, w).sum()
            rot = R.new_zeros(())
        else:
            root, rot = R.new_zeros(()), rotation_temporal_loss(R, w).sum()
        if stage.body_pose:
            rot = rot + temporal_loss(params.body, w).sum()
        total = total + cfg.temporal_weight * rot + root + cfg.temporal_transl_weight * tr
        logs["temporal"] = float(rot.detach())
    return total, logs


def head_prior_weights(face_weights: torch.Tensor | None, cfg: FitConfig, num_frames: int) -> torch.Tensor:
    """(N,) weight of the neck and head prior per frame: ``cfg.head_prior_weight`` where the nose
    and both eyes face the camera, rising to ``cfg.head_prior_hidden_weight`` with the share of
    them hidden (``face_weights`` (N, 5) of :func:`_face_weights`; None: all seen)."""
    if face_weights is None:
        return torch.full((num_frames,), cfg.head_prior_weight)
    hidden = 1.0 - face_weights[:, :3].mean(1)
    return cfg.head_prior_weight + (cfg.head_prior_hidden_weight - cfg.head_prior_weight) * hidden


def _detector_keypoints(problem: FitProblem, out, idx: torch.Tensor) -> torch.Tensor:
    """(B, 23, 3) the posed body's keypoints as the frames ``idx``' detector marks them (the ears)."""
    if problem.ear_offsets is None:
        return out.keypoints3d
    return detector_ears(out.keypoints3d, out.head_rotation, problem.ear_offsets[idx])


def _face_weights(problem: FitProblem, params: FitParameters, chunks) -> torch.Tensor:
    """(N, 5) which face points the pose the stage starts from turns towards the camera, held for
    the stage (:mod:`morf.fitting.face_visibility` says why not step by step)."""
    with torch.no_grad():
        out = [face_point_visibility(_detector_keypoints(problem, problem.body(
            params.pose_matrices(idx), params.shape(idx), proxy_rows=idx.new_zeros(0)), idx), problem.camera_position)
               for idx in chunks]
    weights = torch.cat(out)
    if problem.guessed is not None:  # the truth's own keypoints are where the hidden points are
        weights = torch.where(problem.guessed[:, None], weights, torch.ones_like(weights))
    return weights


def run_stage(problem: FitProblem, params: FitParameters, cfg: FitConfig, stage: StageConfig, *,
              stage_number: int, control: StageControl | None = None) -> dict[str, float]:
    """Optimise ``params`` in place for one stage; returns the last step's loss terms."""
    control = control or StageControl()
    trainable = [params.root_delta, params.transl]
    if stage.body_pose:
        trainable.append(params.body)
    if stage.shape:
        trainable.append(params.shape_logit)
    N = params.num_frames
    device = params.transl.device
    use_sil = cfg.silhouette and stage.silhouette and problem.masks is not None
    use_offsets = use_sil and cfg.offsets and stage.offsets and params.offsets.numel() > 0
    groups_ = [{"params": trainable, "lr": stage.lr}]
    if use_offsets:
        groups_.append({"params": [params.offsets], "lr": cfg.offset_lr})
    opt = Adam(groups_)
    sil_frames = torch.arange(N, device=device)
    if use_sil:
        # frames with a detected person and a non-empty mask take part in the silhouette loss
        usable = torch.as_tensor(problem.inputs.detected, device=device) & (problem.masks.sum((1, 2)) > 1.0)
        sil_frames = sil_frames[usable]
    groups = max(1, round(1.0 / min(1.0, max(cfg.silhouette_frame_fraction, 1e-3))))
    # at least 8 frames per step: on short sequences a rotating eighth is one noisy frame a step
    groups = min(groups, max(1, int(sil_frames.numel()) // 8))
    chunks = torch.arange(N, device=device).split(max(1, cfg.chunk_frames))
    problem.face_weights = _face_weights(problem, params, chunks) if cfg.face_visibility else None
    logs: dict[str, float] = {}
    bar = progress(total=stage.iterations, desc=f"fit {stage_number}/{len(cfg.stages)} {stage.name}", unit="step")
    for it in range(stage.iterations):
        opt.zero_grad(set_to_none=True)
        logs = {}
        sil_now = sil_frames[it % groups::groups] if use_sil else None
        for idx in chunks:
            sil_idx = None
            if sil_now is not None:
                sil_idx = sil_now[(sil_now >= idx[0]) & (sil_now <= idx[-1])]
            loss, part = _data_terms(problem, params, cfg, idx, sil_idx, float(groups), use_offsets)
            loss.backward()
            for k, v in part.items():
                logs[k] = logs.get(k, 0.0) + v
        seq, part = _sequence_terms(problem, params, cfg, stage, use_offsets)
        if seq.requires_grad:
            seq.backward()
        logs.update(part)
        opt.step()
        if use_offsets:
            with torch.no_grad():  # projected gradient: bounded, (almost) outward only
                params.offsets.clamp_(cfg.offset_min, cfg.offset_max)
        bar.update(1)
        if it % 10 == 0 or it == stage.iterations - 1:
            per_frame = {k: v / N for k, v in logs.items()}
            bar.set_postfix({k: f"{v:.3g}" for k, v in per_frame.items()})
            control.report(Progress(stage="fit", step=it + 1, total=stage.iterations,
                                    message=f"fitting {stage.name}, stage {stage_number}/{len(cfg.stages)}",
                                    losses=per_frame))
            control.check()
    bar.close()
    return {k: v / N for k, v in logs.items()}
