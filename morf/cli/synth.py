"""``morf synth DIR``: render a synthetic capture project with ground truth (for tests and benchmarks)."""

from __future__ import annotations


def _shape(text: str) -> tuple[float, ...]:
    import argparse

    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 6 comma-separated numbers, got {text!r}") from None
    return values


def add_parser(sub):
    from morf.presets import PRESETS, default_preset
    from morf.synth.config import CLOTHING, DETECTORS

    p = sub.add_parser("synth", help="render a synthetic capture project with ground truth",
                       description="Render a person turning in place (Anny body, procedural clothes) into a "
                                   "capture project, plus ground_truth/ with poses, camera and a hold-out set.")
    p.add_argument("project", help="folder to create (must be new or empty)")
    p.add_argument("--preset", choices=tuple(PRESETS["synth"]), default=None,
                   help=f"size preset: {' | '.join(PRESETS['synth'])} (default: {default_preset('synth')}; default, "
                        "cpu and gpu are one capture, each recording its name; tiny: tests)")
    p.add_argument("--seed", type=int, help="random seed (clothes, shape, motion, nuisances)")
    p.add_argument("--frames", type=int, help="number of capture frames")
    p.add_argument("--holdout-frames", type=int, help="number of novel-pose hold-out frames")
    p.add_argument("--size", type=int, help="image width and height in pixels")
    p.add_argument("--slide", type=float, help="cloth sliding: largest texture displacement, atlas units")
    p.add_argument("--loose", type=float, help="loose garments: offset at hem and cuffs, metres")
    p.add_argument("--kp-noise", type=float, help="Gaussian noise on ground-truth keypoints, pixels")
    p.add_argument("--corrupt", type=float, help="fraction of frames with keypoints of a wrong pose")
    p.add_argument("--detector", choices=DETECTORS, help="keypoints from MediaPipe (auto/mediapipe) or ground truth (none)")
    p.add_argument("--shape", type=_shape, help="Anny phenotype: 6 comma-separated values in [0, 1]")
    p.add_argument("--clothing", choices=CLOTHING, help="print (patterned, high-frequency) or plain (flat colours)")
    p.add_argument("--turn-degrees", type=float, help="how far the person turns (default 360; < 150 never shows the back)")
    p.add_argument("--config", default=None, metavar="JSON",
                   help="start from a config file (a synthetic project's ground_truth/synth_config.json) "
                        "instead of a preset")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help="set any config field, e.g. --set shading=0.3 --set background=[0,0,0] (repeatable; "
                        "applied last)")
    p.add_argument("--force", action="store_true", help="rebuild an existing synthetic project in place")
    return p


OPTIONS = ("seed", "frames", "holdout_frames", "size", "slide", "loose", "kp_noise", "corrupt", "detector", "shape",
           "clothing", "turn_degrees")


def resolve_config(args):
    """The capture's SynthConfig: the --config file or the --preset, the options given, then --set."""
    from morf.errors import InputError
    from morf.presets import default_preset
    from morf.synth import synth_config
    from morf.synth.config import SynthConfig

    options = {k: getattr(args, k, None) for k in OPTIONS}
    if getattr(args, "config", None):
        from morf.config_checks import read_config_file

        if args.preset:
            raise InputError("--config gives the whole config; use --set to change fields, not --preset")
        d = read_config_file(args.config, "synth config")
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
    return 0
