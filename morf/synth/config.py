"""Synthetic capture settings and their named presets (the one place they are defined)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from morf.config_checks import apply_settings, check_keys, raise_first
from morf.errors import InputError

DETECTORS = ("auto", "mediapipe", "none")
CLOTHING = ("print", "plain")


@dataclass(frozen=True)
class SynthConfig:
    """Everything that decides a synthetic capture; the same config and seed give the same files."""

    preset: str = "default"  # name of the preset this config started from
    seed: int = 0  # seeds clothing, body shape, motion, nuisances and keypoint noise
    frames: int = 240  # capture frames (the turn, then the hands)
    size: int = 512  # image width and height in pixels
    holdout_frames: int = 60  # frames of the novel-pose hold-out sequence
    fps: float = 30.0  # frame rate written to the manifest
    texture_size: int = 1024  # clothing atlas resolution (texels per side)
    shape: tuple[float, ...] | None = None  # Anny phenotype (6 values in [0, 1]); None: drawn from the seed
    fov_deg: float = 40.0  # vertical field of view of the static camera
    person_height_frac: float = 0.8  # standing body height as a share of the image height
    turn_fraction: float = 0.8  # share of the capture spent turning; the rest shows the hands
    turn_degrees: float = 360.0  # how far the person turns (under about 150: the back is never seen)
    clothing: str = "print"  # print: patterned shirt + chest print + twill; plain: flat colours
    sway: float = 1.0  # scale of the natural sway while turning (0: a statue on a turntable)
    arms_out_deg: float = 12.0  # arms raised this far beyond Anny's rest A-pose while turning
    slide: float = 0.006  # cloth sliding: largest texture-space displacement, atlas units (1 = atlas side)
    loose: float = 0.025  # loose garments: outward offset at the shirt hem / trouser cuffs, metres
    kp_noise: float = 1.5  # std of Gaussian noise added to ground-truth keypoints, pixels
    corrupt: float = 0.05  # share of frames whose stored keypoints come from a wrong pose
    detector: str = "auto"  # keypoints: auto (MediaPipe if available), mediapipe (required) or none
    shading: float = 0.7  # Lambert shading strength (0: flat albedo)
    msaa: int = 4  # samples per pixel for the colour frames
    background: tuple[int, int, int] = (118, 124, 130)  # RGB behind the person
    # sparse captures: keep this many frames of the turn, evenly spread over its heading (8 of a
    # 360-degree turn: 45 degrees apart), as a few photos of a turn would show it; 0 keeps every frame
    views: int = 0
    photo_set: bool = False  # with views: recorded as unordered photos (no frame rate, no times)

    def validate(self) -> None:
        """Raise :class:`InputError` naming the first bad setting."""
        checks = [
            (self.frames >= 1, f"--frames must be at least 1, got {self.frames}"),
            (self.frames <= 100_000, f"--frames must be at most 100000, got {self.frames}"),
            (32 <= self.size <= 4096, f"--size must be between 32 and 4096 pixels, got {self.size}"),
            (self.holdout_frames >= 0, f"hold-out frames must be >= 0, got {self.holdout_frames}"),
            (self.fps > 0, f"fps must be positive, got {self.fps}"),
            (64 <= self.texture_size <= 8192, f"texture size must be in 64..8192, got {self.texture_size}"),
            (0 <= self.slide <= 0.05, f"--slide must be in [0, 0.05] atlas units, got {self.slide}"),
            (0 <= self.loose <= 0.2, f"--loose must be in [0, 0.2] metres, got {self.loose}"),
            (self.kp_noise >= 0, f"--kp-noise must be >= 0 pixels, got {self.kp_noise}"),
            (0 <= self.corrupt <= 1, f"--corrupt must be a fraction in [0, 1], got {self.corrupt}"),
            (self.detector in DETECTORS, f"--detector must be one of {', '.join(DETECTORS)}, got {self.detector!r}"),
            (0 < self.person_height_frac <= 1.5, f"person height fraction must be in (0, 1.5], got {self.person_height_frac}"),
            (5 <= self.fov_deg <= 120, f"field of view must be 5..120 degrees, got {self.fov_deg}"),
            (0 < self.turn_fraction <= 1, f"turn fraction must be in (0, 1], got {self.turn_fraction}"),
            (0 <= self.turn_degrees <= 720, f"--turn-degrees must be in [0, 720], got {self.turn_degrees}"),
            (self.clothing in CLOTHING, f"--clothing must be one of {', '.join(CLOTHING)}, got {self.clothing!r}"),
            (self.sway >= 0, f"sway must be >= 0, got {self.sway}"),
            (0 <= self.shading <= 1, f"shading must be in [0, 1], got {self.shading}"),
            (self.msaa >= 0, f"msaa must be >= 0 samples, got {self.msaa}"),
            (0 <= self.views <= self.frames, f"views must lie in 0..frames ({self.frames}), got {self.views}"),
            (not self.photo_set or self.views > 0, "photo_set needs views > 0 (the photos kept of the turn)"),
            (len(self.background) == 3 and all(0 <= c <= 255 for c in self.background),
             f"background must be 3 values in 0..255, got {self.background}"),
        ]
        if self.shape is not None:
            checks.append((len(self.shape) == 6 and all(0 <= s <= 1 for s in self.shape),
                           f"shape must be 6 values in [0, 1], got {self.shape}"))
        raise_first(checks)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "SynthConfig":
        """The config of ``to_dict`` (e.g. ground_truth/synth_config.json), validated; unknown keys
        are an InputError."""
        cfg = SynthConfig(**_tuples(check_keys(SynthConfig, dict(d), "synth config")))
        cfg.validate()
        return cfg

    def with_settings(self, settings: list[str] | tuple[str, ...]) -> "SynthConfig":
        """This config with ``FIELD=VALUE`` settings applied (VALUE read as JSON when it parses, e.g.
        ``shape=[0.5,0.5,0.5,0.5,0.5,0.5]``, else as a string); an unknown field is an InputError."""
        return SynthConfig.from_dict(apply_settings(self.to_dict(), settings))

    def replace(self, **changes) -> "SynthConfig":
        """A validated copy with ``changes``; unknown keys are an InputError."""
        check_keys(SynthConfig, changes, "synth config")
        cfg = dataclasses.replace(self, **_tuples(changes))
        cfg.validate()
        return cfg


def _tuples(d: dict) -> dict:
    """``d`` with its sequence fields as tuples (JSON and the command line give lists)."""
    d = dict(d)
    for key in ("shape", "background"):
        if d.get(key) is not None:
            value = d[key]
            if not isinstance(value, (list, tuple)) or not all(isinstance(v, (int, float)) for v in value):
                raise InputError(f"{key} must be a list of numbers, got {value!r}")
            d[key] = tuple(float(v) for v in value) if key == "shape" else tuple(value)
    return d


# "default" is what a capture is made with when no preset is named (and the name it records).
PRESETS: dict[str, SynthConfig] = {
    # Seconds to build, for tests and CI: detector off (MediaPipe needs larger people).
    "tiny": SynthConfig(preset="tiny", frames=12, size=128, holdout_frames=4, texture_size=512,
                        detector="none"),
    # Sized for real benchmarks of fitting, training and playback.
    "default": SynthConfig(),
    # cpu = gpu = default (but for the recorded name): a capture is data, not compute; the device changes nothing
    "cpu": SynthConfig(preset="cpu"),
    "gpu": SynthConfig(preset="gpu"),
}


def synth_config(preset: str = "default", **overrides) -> SynthConfig:
    """A preset with some fields replaced (``None`` values are ignored), validated."""
    if preset not in PRESETS:
        raise InputError(f"unknown synth preset {preset!r}; choose one of {', '.join(PRESETS)}")
    return PRESETS[preset].replace(**{k: v for k, v in overrides.items() if v is not None})
