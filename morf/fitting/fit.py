"""Fit the body model to every frame of a capture (SMPLify-X-style, with the paper's refinements).

``fit_sequence`` works on in-memory inputs (tests, benchmarks); ``fit_project`` reads a capture
project, resumes from the last completed stage, and writes PROJECT/fits/ atomically.
"""

from __future__ import annotations

import contextlib
import dataclasses
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch

from morf.body.rotations import axis_angle_to_matrix
from morf.fitting import frame_spacing
from morf.fitting.config import FitConfig
from morf.fitting.evaluate import evaluate_fit
from morf.fitting.face_visibility import detector_ears, detector_frames, ear_offsets_per_frame, trust_found_faces
from morf.fitting.fit_body import FitBody
from morf.fitting.fits_io import BodyFits
from morf.fitting.frame_filter import filter_frames, limit_excess, pose_change_deg
from morf.fitting.frame_spacing import FrameSpacing
from morf.fitting.global_init import fit_global
from morf.fitting.heading import HeadingEvidence, exchange_labels
from morf.fitting.inputs import FitInputs
from morf.fitting.head_hands import HeadHandsConfig
from morf.fitting.landmark_refinement import refine_head_hands
from morf.fitting.offsets import proxy_edges, spread_to_mesh
from morf.fitting.optimize import FitProblem, run_stage
from morf.fitting.params import FIT_BONES, FitParameters
from morf.fitting.pose_prior import JointLimitPrior
from morf.fitting.proxy_mesh import body_proxy
from morf.pipeline.control import Progress, StageControl


@dataclass(frozen=True)
class FitState:
    """Fit parameters as plain tensors (CPU, float32).

    Fields:
        rotvecs: (N, J, 3) full model axis-angles; transl: (N, 3); shape: (1 or N, S).
        stage: number of completed stages.
        offsets: (Vp,) clothing offsets of the silhouette proxy's vertices (empty when none).
        spacing: how far apart the fit took the frames to be (None before the first stage).
        swapped: (N,) bool, frames whose keypoints' left/right labels the first stage exchanged
            (:mod:`morf.fitting.heading`); None before the first stage or when none were.
    """

    rotvecs: torch.Tensor
    transl: torch.Tensor
    shape: torch.Tensor
    stage: int
    offsets: torch.Tensor = field(default_factory=lambda: torch.zeros(0))
    spacing: FrameSpacing | None = None
    swapped: np.ndarray | None = None


def with_labels(inputs: FitInputs, swapped: np.ndarray | None) -> FitInputs:
    """``inputs`` with each frame's keypoints read as the first stage chose (left and right
    exchanged where ``swapped``): what every later stage, the evaluation and the filter fit to."""
    if swapped is None or not np.any(swapped):
        return inputs
    return dataclasses.replace(inputs, keypoints=exchange_labels(inputs.keypoints, swapped))


def default_device() -> torch.device:
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")


@contextlib.contextmanager
def cpu_threads(n: int):
    """Temporarily set torch's intra-op CPU threads (0 leaves them alone)."""
    previous = torch.get_num_threads()
    if n > 0:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def known_spacing(inputs: FitInputs, cfg: FitConfig) -> FrameSpacing | None:
    """How far apart the frames are, where the capture says: unordered views, or frame times;
    None when only the fit's first stage can tell (from the heading change between frames)."""
    N = inputs.num_frames
    if not cfg.frame_spacing:
        return frame_spacing.dense(N)
    if inputs.unordered:
        return frame_spacing.unordered(N)
    if inputs.frame_times is not None and len(inputs.frame_times) == N:
        return frame_spacing.from_times(inputs.frame_times)
    return None


def _problem(model, inputs: FitInputs, cfg: FitConfig, device: torch.device) -> FitProblem:
    proxy = body_proxy(model, cfg.proxy_cell) if (cfg.silhouette and inputs.masks is not None) else None
    body = FitBody(model, proxy).to(device)
    ears = ear_offsets_per_frame(inputs.keypoint_source, cfg.detector_ears)
    masks = torch.as_tensor(inputs.masks, device=device) if (proxy is not None) else None
    edges = proxy_edges(proxy.faces).to(device) if proxy is not None else None
    sil_camera = inputs.camera.scaled(inputs.mask_scale) if masks is not None else None
    return FitProblem(body=body, prior=JointLimitPrior(model).to(device), inputs=inputs,
                      keypoints=torch.as_tensor(trust_found_faces(inputs.keypoints, inputs.landmarks,
                                                                  cfg.faceless_face_weight), device=device),
                      masks=masks,
                      sil_camera=sil_camera, shape_mean=model.default_shape().to(device), offset_edges=edges,
                      keypoint_scale=0.01 * inputs.camera.height,
                      camera_position=torch.as_tensor(inputs.camera.position, dtype=torch.float32, device=device),
                      ear_offsets=None if ears is None else ears.to(device),
                      guessed=detector_frames(inputs.keypoint_source, inputs.num_frames).to(device))


def fit_sequence(model, inputs: FitInputs, cfg: FitConfig, *, control: StageControl | None = None,
                 start: FitState | None = None, device: torch.device | None = None,
                 on_stage: Callable[[FitState], None] | None = None) -> FitState:
    """Run the remaining stages of ``cfg`` (all, or those after ``start.stage``).

    Stage 1 is always the rigid global fit (orientation + translation); the others are
    :func:`~morf.fitting.optimize.run_stage` with their own switches.

    ``on_stage`` is called with the state after every completed stage (to save a checkpoint).
    """
    with cpu_threads(cfg.cpu_threads):
        return _fit_sequence(model, inputs, cfg, control or StageControl(), start, device or default_device(), on_stage)


def _fit_sequence(model, inputs, cfg, control, start, device, on_stage) -> FitState:
    torch.manual_seed(cfg.seed)
    model = model.to(device)
    problem = _problem(model, inputs, cfg, device)
    N = inputs.num_frames
    bone_ids = [model.bone_index(b) for b in FIT_BONES]
    shape0 = model.default_shape().to(device)
    n_off = problem.body.proxy_ids.numel() if (cfg.offsets and problem.body.proxy_ids is not None) else 0
    done, state = 0, start
    if start is not None and start.stage > 0:
        params = FitParameters(N, len(model.bone_names), bone_ids, torch.eye(3, device=device).expand(N, 3, 3),
                               start.transl.to(device), shape0, cfg.shared_shape, n_off).to(device)
        params.load_state(start.rotvecs.to(device), start.transl.to(device), start.shape.to(device),
                          start.offsets.to(device))
        done, swapped = start.stage, start.swapped
        spacing = start.spacing or known_spacing(inputs, cfg) or frame_spacing.from_heading(
            axis_angle_to_matrix(start.rotvecs[:, 0]).numpy())
    else:
        first = cfg.stages[0]
        control.report(Progress(stage="fit", message=f"fitting {first.name}, stage 1/{len(cfg.stages)}"))
        with torch.no_grad():
            rest_kp = model(model.zero_pose(1), shape0).keypoints3d[0]
            if problem.ear_offsets is not None:  # the rigid stage fits one rest body: the frames' usual ears
                ears = problem.ear_offsets.median(0).values
                rest_kp = detector_ears(rest_kp[None], torch.eye(3, device=device)[None], ears)[0]
        g = fit_global(inputs.keypoints, inputs.camera, rest_kp.cpu(), hypotheses=cfg.yaw_hypotheses,
                       iterations=first.iterations, lr=first.lr, scale=0.01 * inputs.camera.height,
                       sigma=cfg.keypoint_robust_sigma, switch_weight=cfg.yaw_switch_weight,
                       spacing=known_spacing(inputs, cfg), control=control,
                       evidence=HeadingEvidence() if cfg.front_back else None, turn_aware=cfg.frame_spacing)
        params = FitParameters(N, len(model.bone_names), bone_ids, g.root.to(device), g.transl.to(device),
                               shape0, cfg.shared_shape, n_off).to(device)
        done, spacing = 1, g.spacing
        swapped = g.swapped if g.swapped is not None and g.swapped.any() else None
        state = _stage_done(params, done, on_stage, spacing, swapped)
    if swapped is not None:  # the later stages fit the labels the first stage chose
        problem.inputs = with_labels(inputs, swapped)
        problem.keypoints = torch.as_tensor(problem.inputs.keypoints, device=device)
    problem.pair_weights = torch.as_tensor(spacing.temporal_weights(), dtype=problem.keypoints.dtype, device=device)
    for k in range(done, len(cfg.stages)):
        stage = cfg.stages[k]
        run_stage(problem, params, cfg, stage, stage_number=k + 1, control=control)
        state = _stage_done(params, k + 1, on_stage, spacing, swapped)
    return state  # what the last checkpoint holds (a resumed fit with nothing left returns ``start``)


def _stage_done(params: FitParameters, stage: int, on_stage: Callable[[FitState], None] | None,
                spacing: FrameSpacing, swapped: np.ndarray | None) -> FitState:
    """Hand the state after ``stage`` to ``on_stage`` (the checkpoint) and go on from that very
    state, as a fit resumed from the checkpoint does: the parameters are rebuilt from the saved
    rotvecs and shape (the root's delta folded into its rotation, the shape through its logit),
    so a fit killed after any stage and resumed ends with the same numbers as one that ran through."""
    state = _state(params, stage, spacing, swapped)
    if on_stage is not None:
        on_stage(state)
    device = params.transl.device
    params.load_state(state.rotvecs.to(device), state.transl.to(device), state.shape.to(device),
                      state.offsets.to(device))
    return state


def _state(params: FitParameters, stage: int, spacing: FrameSpacing, swapped: np.ndarray | None) -> FitState:
    """The parameters after ``stage`` as tensors of their own (a copy: never views of the
    parameters, which later stages go on changing)."""
    with torch.no_grad():
        pose = params.pose()
        return FitState(*(t.detach().float().cpu().clone() for t in (pose.rotvecs, pose.transl, params.shape())),
                        stage, params.offsets.detach().float().cpu().clone(), spacing, swapped)


def finalize(model, inputs: FitInputs, cfg: FitConfig, state: FitState) -> tuple[BodyFits, dict[int, str]]:
    """Evaluate the fit on the full mesh and run the frame filter."""
    with cpu_threads(cfg.cpu_threads):
        return _finalize(model, inputs, cfg, state)


def _finalize(model, inputs: FitInputs, cfg: FitConfig, state: FitState) -> tuple[BodyFits, dict[int, str]]:
    inputs = with_labels(inputs, state.swapped)
    device = next(iter(model.buffers())).device
    landmark_px = None
    if cfg.head_hands and inputs.landmarks is not None:
        rotvecs, landmark_px = refine_head_hands(model, state.rotvecs.numpy(), state.transl.numpy(),
                                                 state.shape.numpy(), inputs.camera, inputs.landmarks, state.swapped,
                                                 None if state.spacing is None else state.spacing.gaps,
                                                 HeadHandsConfig(profile_eye_visibility=cfg.profile_face_visibility,
                                                                 face_yaw_full=cfg.face_yaw_full,
                                                                 face_yaw_none=cfg.face_yaw_none,
                                                                 temporal=cfg.landmark_temporal_weight))
        state = dataclasses.replace(state, rotvecs=torch.as_tensor(rotvecs))
    rv, tr, sh = (x.to(device) for x in (state.rotvecs, state.transl, state.shape))
    offsets = None
    if state.offsets.numel() > 0 and bool((state.offsets != 0).any()):
        offsets = spread_to_mesh(model, body_proxy(model, cfg.proxy_cell).vertex_ids, state.offsets).to(device)
    ev = evaluate_fit(model, rv, tr, sh, inputs.keypoints, inputs.camera, inputs.masks_eval, inputs.eval_scale,
                      cfg.filter.min_confidence, offsets=offsets)
    fits = BodyFits(rotvecs=state.rotvecs.numpy(), transl=state.transl.numpy(), shape=state.shape.numpy(),
                    keypoint_residual_px=ev.keypoint_residual_px, keypoint_worst_px=ev.keypoint_worst_px,
                    silhouette_iou=ev.silhouette_iou, silhouette_iou_body=ev.silhouette_iou_body,
                    offsets=None if offsets is None else offsets.cpu().numpy(),
                    projected_keypoints=ev.projected_keypoints, config=cfg.to_dict(), twist_deg=ev.twist_deg,
                    label_swapped=state.swapped, landmark_residual_px=landmark_px)
    rejected: dict[int, str] = {}
    if cfg.frame_filter:
        bone_ids = [model.bone_index(b) for b in FIT_BONES]
        root = axis_angle_to_matrix(state.rotvecs[:, 0]).numpy()
        change = pose_change_deg(root, state.rotvecs[:, bone_ids].numpy())
        confident = (inputs.keypoints[..., 2] > cfg.filter.min_confidence).sum(1)
        with torch.no_grad():
            excess = JointLimitPrior(model).to(device).excess_deg(rv[:, bone_ids]).cpu().numpy()
        spacing = state.spacing or known_spacing(inputs, cfg) or frame_spacing.from_heading(root)
        rejected = filter_frames(residual_px=ev.keypoint_worst_px, confident=confident, detected=inputs.detected,
                                 iou=ev.silhouette_iou if inputs.masks_eval is not None else None,
                                 change_deg=change, image_height=inputs.camera.height, cfg=cfg.filter,
                                 twist_deg=ev.twist_deg, limits=limit_excess(excess, FIT_BONES),
                                 neighbours=spacing.neighbours())
    return fits, dict(sorted(rejected.items()))

