"""Typed configuration of the body fit, with named presets and the ablation switches.

The four refinements of the paper's mesh fitting are switches here so that each can be
ablated (``morf bench fitting``): ``shared_shape``, ``silhouette``, ``temporal``, ``frame_filter``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from morf.config_checks import apply_settings, check_field_kinds, check_keys, raise_first
from morf.errors import InputError


@dataclass(frozen=True)
class StageConfig:
    """One stage of the staged optimisation."""

    name: str  # "global" | "body" | "all"
    iterations: int  # Adam steps
    lr: float  # Adam learning rate
    body_pose: bool  # optimise the body bones' rotations
    shape: bool  # optimise the shape
    silhouette: bool  # add the silhouette loss (when FitConfig.silhouette is on)
    offsets: bool = False  # optimise the clothing offsets (when FitConfig.offsets and the silhouette are on)

    def validate(self) -> None:
        check_field_kinds(self, "fit config", f"stage {self.name!r} ")
        if not self.name:
            raise InputError("every fit stage needs a name")
        if self.iterations < 0:
            raise InputError(f"fit stage {self.name!r}: iterations must be >= 0, got {self.iterations}")
        if not self.lr > 0:
            raise InputError(f"fit stage {self.name!r}: the learning rate must be positive, got {self.lr}")


def default_stages() -> tuple[StageConfig, ...]:
    return (
        StageConfig("global", 60, 0.06, body_pose=False, shape=False, silhouette=False),
        StageConfig("body", 140, 0.03, body_pose=True, shape=False, silhouette=False),
        StageConfig("all", 60, 0.015, body_pose=True, shape=True, silhouette=True, offsets=True),
    )


@dataclass(frozen=True)
class FilterConfig:
    """Thresholds of the automatic frame filter (a frame is rejected when any one fires)."""

    residual_factor: float = 3.0  # keypoint residual above this many times the sequence median ...
    residual_min_px: float = 0.02  # ... and above this fraction of the image height
    iou_drop: float = 0.12  # silhouette IoU this far below the sequence median (when masks exist)
    jump_factor: float = 4.0  # pose change to BOTH neighbours above this many times the median change ...
    jump_min_deg: float = 12.0  # ... and above this many degrees (mean of the 3 bones that moved most)
    max_twist_deg: float = 30.0  # pelvis-shoulder twist above this many degrees (twist.py)
    limit_excess_deg: float = 25.0  # a fitted bone further than this outside its joint limits (pose_prior.py)
    min_keypoints: int = 6  # fewer confident keypoints than this counts as a detection failure
    min_confidence: float = 0.3  # a keypoint counts as confident above this

    def validate(self) -> None:
        check_field_kinds(self, "fit config", "filter.")
        checks = [
            (self.residual_factor > 0, f"filter.residual_factor must be positive, got {self.residual_factor}"),
            (self.residual_min_px >= 0, f"filter.residual_min_px must be >= 0, got {self.residual_min_px}"),
            (self.iou_drop >= 0, f"filter.iou_drop must be >= 0, got {self.iou_drop}"),
            (self.jump_factor > 0, f"filter.jump_factor must be positive, got {self.jump_factor}"),
            (self.jump_min_deg >= 0, f"filter.jump_min_deg must be >= 0 degrees, got {self.jump_min_deg}"),
            (0 < self.max_twist_deg <= 180, f"filter.max_twist_deg must lie in (0, 180] degrees, got {self.max_twist_deg}"),
            (self.limit_excess_deg > 0, f"filter.limit_excess_deg must be positive degrees, got {self.limit_excess_deg}"),
            (self.min_keypoints >= 0, f"filter.min_keypoints must be >= 0, got {self.min_keypoints}"),
            (0 <= self.min_confidence <= 1, f"filter.min_confidence must lie in [0, 1], got {self.min_confidence}"),
        ]
        raise_first(checks)


@dataclass(frozen=True)
class FitConfig:
    """Everything that decides a fit. Saved as PROJECT/fits/fit_config.json."""

    # the paper's refinements (each can be switched off for the ablation)
    shared_shape: bool = True  # one shape for all frames (else one per frame)
    silhouette: bool = True  # Dice loss between the rendered body silhouette and the person mask
    temporal: bool = True  # L2 between adjacent frames' pose vectors and translations
    # scale the temporal terms and the heading choice by how far apart frames are (frame times, else
    # the heading change; none between unordered views: frame_spacing.py); off: every pair 33 ms apart
    frame_spacing: bool = True
    frame_filter: bool = True  # flag unreliable frames in fits/filter.json

    stages: tuple[StageConfig, ...] = field(default_factory=default_stages)

    # loss weights (keypoint residuals are measured in percent of the image height)
    keypoint_weight: float = 1.0
    keypoint_robust_sigma: float = 5.0  # Geman-McClure scale, percent of the image height
    pose_prior_weight: float = 0.02  # joint-limit prior
    pose_l2_weight: float = 0.002  # weak pull towards the rest A-pose
    # pull of the neck's and the head's rotations towards upright on the chest (radians^2): the
    # body keypoints hold the head by five face points, and where those are hidden the head was
    # free to wander (docs/fitting.md "The head's orientation"): head_prior_weight where the nose
    # and both eyes face the camera, rising to head_prior_hidden_weight where none does (a back
    # view, the ears left). Stronger weights fit the synthetic capture's upright head better
    # (30 everywhere: 6.6 degrees against 7.2) but take more off a real nod or tilt
    head_prior_weight: float = 10.0
    head_prior_hidden_weight: float = 30.0
    twist_weight: float = 100.0  # pelvis-shoulder twist beyond twist_limit_deg (twist.py)
    twist_limit_deg: float = 25.0  # twist the penalty allows for free
    shape_weight: float = 0.5  # shape regularisation towards the default phenotype
    temporal_weight: float = 300.0  # adjacent-frame pose differences (radians^2); tuned on the default capture
    temporal_transl_weight: float = 3e4  # adjacent-frame translation differences (metres^2)
    # what the temporal term penalises in the body's orientation: "speed" (first differences, weight
    # temporal_weight; holds back a brisk turn at its ends) or "acceleration" (second differences,
    # weight root_acceleration_weight; free for a turn at constant speed; losses.py)
    root_smoothing: str = "speed"
    root_acceleration_weight: float = 300.0
    silhouette_weight: float = 30.0  # Dice loss (10 -> 30: IoU +0.003 on the default capture, same jitter)
    # raster size of the long image side for the silhouette loss: at 96 px a pixel is 2 cm and the
    # 1-2 cm misfits that decide IoU at 256 px were below its resolution (IoU 0.87 vs 0.90 at 192,
    # 0.905 at 256)
    silhouette_resolution: int = 256
    # softness of the rasterizer, pixels of that raster. The soft fringe outside the outline adds
    # area that the Dice loss pays for by shrinking the body (0.14 px per outline pixel at 0.5);
    # 0.12 keeps a gradient band of a third of a pixel (IoU 0.905 -> 0.917; 0.06 lost the gradient: 0.913)
    silhouette_sigma: float = 0.12
    silhouette_frame_fraction: float = 0.125  # share of frames rendered per step (rotating subsets)
    # clothing offsets (offsets.py): in [offset_min, offset_max] metres, smooth over the proxy mesh
    offsets: bool = True
    offset_max: float = 0.06
    offset_min: float = -0.015  # below 0 lets the surface shrink a little (fingers spread wider than the mask's hands)
    offset_lr: float = 0.008  # Adam learning rate of the offsets, metres per step
    offset_smooth_weight: float = 30.0  # squared offset differences over proxy edges (m^2)
    offset_l2_weight: float = 0.1  # squared offsets (m^2), keeps them where the masks ask for them
    proxy_cell: float = 0.03  # vertex-clustering cell of the silhouette proxy mesh, metres
    yaw_hypotheses: int = 8  # initial body orientations tried per frame
    yaw_switch_weight: float = 0.5  # cost of turning between frames when choosing among them
    # try every heading also with the keypoints' left/right labels exchanged, the face deciding
    # between a front view and its mirror-image back view (heading.py); off: the labels as given
    front_back: bool = True
    # after the last stage, turn the head, the wrists and the fingers to the face and hand landmarks
    # where the project has them (head_hands.py; detected by ingest, or OpenPose's face and hands)
    head_hands: bool = True
    # fit the body keypoints' ears where a pose detector marks them (near the ear canal), not on the
    # body model's auricle (face_visibility.py; head error on the default capture, below)
    detector_ears: bool = True
    # weight the nose, eyes and ears by whether the fitted head turns them towards the camera: a
    # detector's guesses at hidden face points (a face on the back of the head) tilted the head
    face_visibility: bool = True
    # > 0: the head-and-hands step leaves a face mesh out where the pose turns an eye away from the
    # camera further than this visibility (a profile, whose far eye the face mesh guesses; 0.5 turned
    # People-Snapshot's profiles right, head_hands.hide_profile_faces); 0: every face counts
    profile_face_visibility: float = 0.0
    # the head-and-hands step counts a face fully where the pose turns the head at most
    # face_yaw_full degrees from the camera, not at all from face_yaw_none (180: every face fully;
    # head_hands.face_yaw_weights), and ties neighbouring frames' changes together with
    # landmark_temporal_weight (radians^2, scaled by the frames' spacing as the temporal terms are,
    # and by the head's size in the image)
    face_yaw_full: float = 30.0
    face_yaw_none: float = 60.0
    landmark_temporal_weight: float = 300.0
    # the body keypoints' nose and eyes count this much in frames where the face mesh, which found
    # faces elsewhere in the capture, found none (face_visibility.trust_found_faces; 1: as given)
    faceless_face_weight: float = 1.0

    # evaluation and outputs
    iou_resolution: int = 256  # raster size of the long image side for silhouette IoU
    overlays: bool = True  # write fits/overlays/000000.jpg per frame
    chunk_frames: int = 256  # frames per forward pass (bounds memory; gradients are accumulated)
    # torch CPU threads while fitting: the steps are many small ops, and on a busy 2-core machine
    # two threads were measured 3-20x slower than one (synchronisation, not arithmetic); 0 = keep
    cpu_threads: int = 1
    seed: int = 0
    filter: FilterConfig = field(default_factory=FilterConfig)

    def replace(self, **changes) -> "FitConfig":
        """A validated copy with ``changes``; unknown keys are an InputError."""
        check_keys(FitConfig, changes, "fitting config")
        cfg = dataclasses.replace(self, **changes)
        cfg.validate()
        return cfg

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "FitConfig":
        """The config of ``to_dict`` (e.g. PROJECT/fits/fit_config.json); unknown keys are an InputError."""
        d = dict(d)
        check_keys(FitConfig, d, "fit config")
        stages = tuple(StageConfig(**check_keys(StageConfig, s, "fit stage")) for s in d.pop("stages", []))
        filt = FilterConfig(**check_keys(FilterConfig, d.pop("filter", {}), "frame filter config"))
        cfg = FitConfig(stages=stages or default_stages(), filter=filt, **d)
        cfg.validate()
        return cfg

    def with_settings(self, settings: list[str] | tuple[str, ...]) -> "FitConfig":
        """This config with ``FIELD=VALUE`` settings applied (``filter.iou_drop=0.1`` and
        ``stages.2.iterations=30``: nested fields); VALUE is read as JSON when it parses, else as a
        string; an unknown field is an InputError naming the known ones."""
        return FitConfig.from_dict(apply_settings(self.to_dict(), settings))

    def validate(self) -> None:
        """Raise :class:`InputError` naming the first setting that makes no sense."""
        check_field_kinds(self, "fit config")
        if not self.stages:
            raise InputError("a fit needs at least one stage")
        for stage in self.stages:
            stage.validate()
        weights = ("keypoint_weight", "pose_prior_weight", "pose_l2_weight", "head_prior_weight",
                   "head_prior_hidden_weight", "twist_weight", "shape_weight", "temporal_weight",
                   "temporal_transl_weight", "silhouette_weight", "offset_smooth_weight", "offset_l2_weight",
                   "yaw_switch_weight", "root_acceleration_weight")
        checks = [(getattr(self, w) >= 0, f"{w} must be >= 0, got {getattr(self, w)}") for w in weights]
        checks += [
            (self.keypoint_robust_sigma > 0, f"keypoint_robust_sigma must be positive, got {self.keypoint_robust_sigma}"),
            (self.silhouette_resolution >= 1, f"silhouette_resolution must be >= 1 pixel, got {self.silhouette_resolution}"),
            (self.iou_resolution >= 1, f"iou_resolution must be >= 1 pixel, got {self.iou_resolution}"),
            (self.silhouette_sigma > 0, f"silhouette_sigma must be positive, got {self.silhouette_sigma}"),
            (0 < self.silhouette_frame_fraction <= 1,
             f"silhouette_frame_fraction must lie in (0, 1], got {self.silhouette_frame_fraction}"),
            (self.offset_min <= 0 <= self.offset_max,
             f"offsets start at 0: need offset_min <= 0 <= offset_max, got [{self.offset_min}, {self.offset_max}]"),
            (self.offset_lr > 0, f"offset_lr must be positive, got {self.offset_lr}"),
            (self.proxy_cell > 0, f"proxy_cell must be positive metres, got {self.proxy_cell}"),
            (0 <= self.twist_limit_deg < 180, f"twist_limit_deg must lie in [0, 180) degrees, got {self.twist_limit_deg}"),
            (self.root_smoothing in ("speed", "acceleration"),
             f"root_smoothing must be 'speed' or 'acceleration', got {self.root_smoothing!r}"),
            (self.yaw_hypotheses >= 1, f"yaw_hypotheses must be >= 1, got {self.yaw_hypotheses}"),
            (self.chunk_frames >= 1, f"chunk_frames must be >= 1, got {self.chunk_frames}"),
            (self.cpu_threads >= 0, f"cpu_threads must be >= 0 (0: keep torch's setting), got {self.cpu_threads}"),
            (self.seed >= 0, f"seed must be >= 0, got {self.seed}"),
            (0 <= self.faceless_face_weight <= 1,
             f"faceless_face_weight must be in [0, 1], got {self.faceless_face_weight}"),
            (0 <= self.profile_face_visibility <= 1,
             f"profile_face_visibility must be in [0, 1], got {self.profile_face_visibility}"),
            (0 <= self.face_yaw_full < self.face_yaw_none <= 180,
             f"need 0 <= face_yaw_full < face_yaw_none <= 180 degrees, got {self.face_yaw_full} and {self.face_yaw_none}"),
            (self.landmark_temporal_weight >= 0,
             f"landmark_temporal_weight must be >= 0, got {self.landmark_temporal_weight}"),
        ]
        raise_first(checks)
        self.filter.validate()


def _scaled(stages: tuple[StageConfig, ...], *factors: float) -> tuple[StageConfig, ...]:
    """Stages with their step counts scaled (one factor per stage; the last one repeats)."""
    f = [factors[min(i, len(factors) - 1)] for i in range(len(stages))]
    return tuple(dataclasses.replace(s, iterations=max(5, int(round(s.iterations * k)))) for s, k in zip(stages, f))


def _with_iterations(stages: tuple[StageConfig, ...], *iterations: int) -> tuple[StageConfig, ...]:
    """Stages with these step counts, one per stage."""
    return tuple(dataclasses.replace(s, iterations=n) for s, n in zip(stages, iterations, strict=True))


# Named presets: "cpu" / "gpu" for real use, "default" the one a fit runs with when none is named
# (the device's preset: all three are one config, and a FitConfig records no name, so
# fits/fit_config.json is the same whichever was named); "fast" for previews; "tiny" for tests (a
# few seconds on a dozen small frames, far from converged); "baseline" is SMPLify-style fitting
# without any of the paper's refinements. New names go after "default": a stopped fit resumes under
# the first name whose config matches (morf.cli.project_steps.fit_options).
_DEVICE_DEFAULT = FitConfig()
PRESETS: dict[str, FitConfig] = {
    "default": _DEVICE_DEFAULT,
    # the last stage keeps 32 of its 60 steps: 24 left the shape and offsets visibly unconverged
    "fast": FitConfig(stages=_scaled(default_stages(), 0.4, 0.4, 0.53), overlays=False),
    "tiny": FitConfig(stages=_with_iterations(default_stages(), 10, 20, 6)),
    "baseline": FitConfig(shared_shape=False, silhouette=False, temporal=False, frame_filter=False),
    # cpu = gpu = default: the steps are where a per-frame fit converges, not a compute budget (no heavier fit measured)
    "cpu": _DEVICE_DEFAULT,
    "gpu": _DEVICE_DEFAULT,
}


def preset(name: str) -> FitConfig:
    """The named fit preset; an unknown name is an InputError listing the known ones."""
    if name not in PRESETS:
        raise InputError(f"unknown fit preset {name!r}; choose one of {', '.join(PRESETS)}")
    return PRESETS[name]
