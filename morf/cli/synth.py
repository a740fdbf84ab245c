"""``morf synth DIR``: render a synthetic capture project with ground truth (for tests and benchmarks)."""

from __future__ import annotations

import importlib.util

from morf.cli.options import add_config_options, add_force_option, read_config_option
from morf.synth.config import CLOTHING, DETECTORS, SynthConfig


def _shape(text: str) -> tuple[float, ...]:
    import argparse

    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 6 comma-separated numbers, got {text!r}") from None
    return values


# The SynthConfig fields a flag of their own overrides (--kp-noise sets kp_noise): field -> (the
# value's type, or its choices, and the help). Given flags replace the preset's or --config's values.
OVERRIDES = {
    "seed": (int, "random seed (clothes, shape, motion, nuisances)"),
    "frames": (int, "number of capture frames"),
    "holdout_frames": (int, "number of novel-pose hold-out frames"),
    "size": (int, "image width and height in pixels"),
    "slide": (float, "cloth sliding: largest texture displacement, atlas units"),
    "loose": (float, "loose garments: offset at hem and cuffs, metres"),
    "kp_noise": (float, "Gaussian noise on ground-truth keypoints, pixels"),
    "corrupt": (float, "fraction of frames with keypoints of a wrong pose"),
    "detector": (DETECTORS, "keypoints from MediaPipe (auto/mediapipe) or ground truth (none)"),
    "shape": (_shape, "Anny phenotype: 6 comma-separated values in [0, 1]"),
    "clothing": (CLOTHING, "print (patterned, high-frequency) or plain (flat colours)"),
    "turn_degrees": (float, "how far the person turns (default 360; < 150 never shows the back)"),
}


def add_parser(sub):
    from morf.presets import PRESETS, default_preset

    p = sub.add_parser("synth", help="render a synthetic capture project with ground truth",
                       description="Render a person turning in place (Anny body, procedural clothes) into a "
                                   "capture project, plus ground_truth/ with poses, camera and a hold-out set.")
    p.add_argument("project", help="folder to create (must be new or empty)")
    p.add_argument("--preset", choices=tuple(PRESETS["synth"]), default=None,
                   help=f"size preset: {' | '.join(PRESETS['synth'])} (default: {default_preset('synth')}; default, "
                        "cpu and gpu are one capture, each recording its name; tiny: tests)")
    for field, (kind, text) in OVERRIDES.items():
        typed = {"choices": kind} if isinstance(kind, tuple) else {"type": kind}
        p.add_argument("--" + field.replace("_", "-"), help=text, **typed)
    add_config_options(p, "a synthetic project's ground_truth/synth_config.json",
                       ("shading=0.3", "background=[0,0,0]"))
    add_force_option(p, "rebuild an existing synthetic project in place")
    return p


def resolve_config(args):
    """The capture's SynthConfig: the --config file or the --preset, the options given, then --set."""
    from morf.presets import default_preset
    from morf.synth import synth_config

    options = {k: getattr(args, k, None) for k in OVERRIDES}
    d = read_config_option(args, "synth config")
    if d is not None:
        if set(d) <= {"config", "resolved"} and isinstance(d.get("config"), dict):
            d = d["config"]  # ground_truth/synth_config.json: the config and what it resolved to
        config = SynthConfig.from_dict(d).replace(**{k: v for k, v in options.items() if v is not None})
    else:
        config = synth_config(args.preset or default_preset("synth"), **options)
    if getattr(args, "set", None):
        config = config.with_settings(args.set)
    return config


def run(args) -> int:
    from morf.synth import make_synthetic_capture

    config = resolve_config(args)
    project = make_synthetic_capture(args.project, config, overwrite=args.force)
    kp = project.load_keypoints()
    n_det = int((kp.source == "mediapipe").sum())
    print(f"wrote {project.num_frames} frames ({config.size}x{config.size}) and {config.holdout_frames} hold-out "
          f"frames to {project.root}; keypoints: {n_det} from MediaPipe, {project.num_frames - n_det} ground truth")
    if n_det == 0 and config.detector == "auto" and importlib.util.find_spec("mediapipe") is None:
        print("MediaPipe is not installed, so the keypoints are the ground truth's; to detect them as on a real "
              "video: pip install --no-deps mediapipe==0.10.14")
    return 0
