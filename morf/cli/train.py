"""``morf train PROJECT``: train (or resume) a neural avatar on a capture project.

Runs live in ``PROJECT/runs/<name>`` (default name ``<method>-<preset>``). Running the same
command again resumes a stopped or killed run from its last checkpoint; Ctrl-C stops cleanly
after writing a checkpoint.
"""

from __future__ import annotations

import signal
import sys

from morf.cli.options import add_config_options, add_fits_option, add_weights_option, read_config_option
from morf.io.names import check_name
from morf.presets import PRESETS
from morf.train.config import METHODS


def add_parser(sub):
    p = sub.add_parser("train", help="train a neural avatar (resumes an unfinished run)")
    p.add_argument("project", help="capture project folder (after 'morf fit')")
    p.add_argument("--method", choices=METHODS, default="morf",
                   help="morf: texture warping (default); stylepeople: no warping; anr: split optimisation; "
                        "rgb: the no-learning floor (the frames projected into a colour texture, seconds)")
    p.add_argument("--preset", choices=(*PRESETS["train"], "auto"), default=None,
                   help="model and schedule sizes (default: gpu when CUDA is present, else cpu); detail: the "
                        "cpu preset with the face and hands trained at the player's density (about half an hour "
                        "on 2 cores); auto: the smallest texture and renderer the capture needs, chosen from the "
                        "capture itself")
    p.add_argument("--name", default=None, help="run name under PROJECT/runs (default: METHOD-PRESET)")
    p.add_argument("--steps", type=int, default=None, help="override the preset's number of steps")
    p.add_argument("--resolution", type=int, default=None, help="override the working image side (pixels)")
    p.add_argument("--crop", type=int, default=None, help="override the random crop side (0: whole image)")
    p.add_argument("--batch-size", type=int, default=None, help="override the batch size")
    p.add_argument("--lr-decay-start", type=float, default=None, metavar="FRAC",
                   help="from this fraction of the steps on, the learning rates follow a cosine down to a tenth "
                        "(default: the preset's; cpu 0.5, gpu 1 = constant rates; docs/benchmarks.md has what it changed)")
    p.add_argument("--ema", type=float, default=None, metavar="DECAY",
                   help="make the avatar from a moving average of the weights with this decay per step, e.g. 0.998 "
                        "(default: the preset's; cpu 0.998, gpu 0 = the last step's weights)")
    p.add_argument("--holdout", type=int, default=None, metavar="K",
                   help="keep the usable frames numbered 0, K, 2K, ... out of training (K >= 2) for 'morf eval' "
                        "(default 0: none)")
    add_fits_option(p, "body fits to train on: fits/fits.npz, or a synthetic capture's ground truth")
    add_weights_option(p, "--vgg", "VGG-16 weights (torchvision state dict) for the perceptual loss; else "
                                   "$MORF_VGG16_WEIGHTS; without them the SSIM term carries the structure (train.log "
                                   "says which term a run used)")
    p.add_argument("--renderer", default=None, metavar="NAME",
                   help="renderer size instead of the preset's: stem2_b8, stem2_b16, stem2_b24, stem4_b8, stem4_b16 (cpu), "
                        "stem4_b24, stem4_b32, stem4_b48, plain_b16 (see docs/benchmarks.md for speed against quality)")
    p.add_argument("--device", default="auto", help="auto (CUDA when present), cpu or cuda")
    add_config_options(p, "a run's config.json", ("texture_size=512", "renderer.width=24"))
    p.add_argument("--restart", action="store_true", help="delete what an existing run of that name wrote and start over")
    return p


def resolve_config(args, project=None):
    """The run's TrainConfig, and the reasons for an automatic size choice (empty otherwise)."""
    cfg, reasons = _base_config(args, project)
    if getattr(args, "set", None):
        cfg = cfg.with_settings(args.set)
    return cfg, reasons


def _base_config(args, project=None):
    from morf.presets import default_preset, preset

    base = default_preset("train")
    overrides = {k: v for k, v in (("steps", args.steps), ("resolution", args.resolution), ("crop", args.crop),
                                   ("batch_size", args.batch_size),
                                   ("lr_decay_start", getattr(args, "lr_decay_start", None)),
                                   ("ema_decay", getattr(args, "ema", None)),
                                   ("holdout", getattr(args, "holdout", None))) if v is not None}
    d = read_config_option(args, "training config", instead_of=("preset", "renderer"))
    if d is not None:
        from morf.train.config import TrainConfig

        d.update(method=args.method if args.method != "morf" else d.get("method", "morf"), device=args.device, **overrides)
        return TrainConfig.from_dict(d), []
    if getattr(args, "renderer", None):
        import dataclasses

        from morf.errors import InputError
        from morf.sizing.sweep import renderer_fields

        if args.preset == "auto":
            raise InputError("--renderer and --preset auto both choose the renderer; give one of them")
        cfg = preset("train", args.preset or base).replace(method=args.method, device=args.device, **overrides)
        rcfg = dataclasses.replace(cfg.renderer, in_channels=cfg.texture_channels, **renderer_fields(args.renderer))
        return cfg.replace(renderer=rcfg), []
    if args.preset == "auto":
        from morf.body import load_body_model
        from morf.sizing.choose import choose_train_config

        return choose_train_config(project, base_preset=base, method=args.method, model=load_body_model("anny"),
                                   device=args.device, **overrides)
    return preset("train", args.preset or base).replace(method=args.method, device=args.device, **overrides), []


def run(args) -> int:
    from morf.capture.project import CaptureProject

    project = CaptureProject.open(args.project)  # the cheap checks first: the training stack takes seconds to load
    if args.name is not None:
        check_name(args.name, "run name")
    cfg, reasons = resolve_config(args, project)

    from morf.pipeline.control import StageControl, StopRequested
    from morf.progress import progress
    from morf.train.project_run import train_project

    if reasons:
        from morf.io import atomic_write_text
        from morf.train.project_run import default_run_name
        from morf.train.run_files import AUTO_SIZE_FILE, run_path

        print("automatic size choice:\n  " + "\n  ".join(reasons))
        atomic_write_text(run_path(project, args.name or default_run_name(cfg)) / AUTO_SIZE_FILE,
                          "\n".join(reasons) + "\n")
    bar = progress(total=cfg.steps if cfg.method != "rgb" else None, desc=f"train {cfg.method}", unit="step")

    def on_progress(p):
        if p.message:
            bar.set_description_str(p.message[:40], refresh=False)
        if p.total and p.step:
            bar.n = p.step
            if p.losses:
                bar.set_postfix({k: f"{v:.3f}" for k, v in p.losses.items() if k in ("l1", "dice", "total")}, refresh=False)
        bar.refresh()

    control = StageControl(on_progress)
    previous = signal.signal(signal.SIGINT, lambda *_: control.stop())
    try:
        result = train_project(project, cfg, args.name, control, args.fits, args.vgg, args.restart)
    except StopRequested:
        bar.close()
        print("morf train: stopped; run the same command to resume", file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGINT, previous)
        bar.close()
    if cfg.method == "rgb":
        done = "built in" if result.losses else "already built in"
        print(f"RGB floor {done} {result.run_dir} (the training frames projected into a colour texture, no learning)")
        return 0
    if result.resumed_from >= result.step and not result.losses:
        print(f"{result.run_dir} is already trained ({result.step} steps); use --restart to train it again")
        return 0
    resumed = f" (resumed at step {result.resumed_from})" if result.resumed_from else ""
    print(f"trained {result.run_dir} : {result.step} steps in {result.train_minutes:.1f} min{resumed}")
    if result.losses:
        print("final losses: " + ", ".join(f"{k} {v:.4f}" for k, v in result.losses.items()))
    return 0
