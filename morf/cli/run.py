"""``morf run PROJECT --video clip.mp4``: the whole path from a video to an exported avatar.

ingest -> fit -> train -> export, each the same sub-command a user would run by hand. A stage
whose output is complete is skipped and a stopped one resumes (a fit after its last finished
stage, a training run from its checkpoint), so the same command run again continues where the
last one stopped; without ``--video`` an existing project continues from where it is, with the
training size and hold-out the last ``morf run`` on it chose (PROJECT/run.json).
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass
from pathlib import Path

from morf.presets import PRESETS

STAGES = ("ingest", "fit", "train", "export")
RUN_FILE = "run.json"  # PROJECT/run.json: the training size and hold-out 'morf run' chose, for the next 'morf run'


def add_parser(sub):
    p = sub.add_parser("run", help="video -> exported avatar in one command (ingest, fit, train, export; "
                                   "finished stages are skipped, stopped ones resume)",
                       description="Run ingest, fit, train and export on a capture project. Each stage is the "
                                   "sub-command of the same name; a stage whose output is complete is skipped and "
                                   "a stopped one resumes, so running the command again continues where it "
                                   "stopped.")
    p.add_argument("project", help="capture project folder (created from --video, or an existing project)")
    p.add_argument("--video", type=Path, metavar="FILE",
                   help="the video to ingest (needed only while the project does not exist yet)")
    p.add_argument("--until", choices=STAGES, default="export", help="stop after this stage (default export)")
    p.add_argument("--preset", choices=(*PRESETS["train"], "auto"), default=None,
                   help=f"training size: {' | '.join((*PRESETS['train'], 'auto'))} (as 'morf train --preset'; "
                        "tiny, cpu and gpu also name the fit preset, auto fits with the default one); default: the "
                        "last 'morf run' on the project's, else its latest training run's, else gpu with CUDA and "
                        "cpu without")
    p.add_argument("--holdout", type=int, default=None, metavar="K",
                   help="keep the usable frames numbered 0, K, 2K, ... out of training for 'morf eval' (K >= 2; "
                        "default: the last 'morf run' on the project's, else none)")
    p.add_argument("--keypoints", type=Path, metavar="DIR",
                   help="with --video: OpenPose JSON per frame instead of MediaPipe (as 'morf ingest')")
    p.add_argument("--masks", type=Path, metavar="DIR",
                   help="with --video: person mask images instead of MediaPipe's (as 'morf ingest')")
    for flag, meta, text in (("--every", "K", "keep every K-th frame"), ("--max-frames", "N", "keep at most N frames"),
                             ("--resize", "PX", "scale frames so the longest side is PX pixels")):
        p.add_argument(flag, type=int, metavar=meta, help=f"with --video: {text} (as 'morf ingest')")
    p.add_argument("--no-mirror-average", dest="no_mirror_average", action="store_true",
                   help="with --video: MediaPipe's keypoints from the frame alone, not averaged with the mirrored "
                        "frame's (as 'morf ingest')")
    return p


@dataclass(frozen=True)
class RunPlan:
    """What ``morf run`` will do: its steps (``morf.pipeline.chain.Step``, up to ``--until``), the
    training run's name and preset and why that preset, and the hold-out. The studio's worker runs
    the same plan, so a project made in the app continues with ``morf run`` and the other way round."""

    steps: tuple
    name: str
    preset: str
    why: str
    holdout: int | None


def plan_run(args, ingest=None) -> RunPlan:
    """Plan ``morf run`` for parsed ``args`` (checks the project and the video first: an InputError
    before anything runs). ``ingest``: a ``Plan`` that replaces the video's ingest (a frames folder)."""
    from morf.cli.project_steps import export_plan, fit_plan, train_plan
    from morf.errors import InputError
    from morf.pipeline.chain import Step

    root = Path(args.project)
    if args.holdout is not None and args.holdout < 2:
        raise InputError(f"--holdout must be at least 2 (every K-th frame kept out), got {args.holdout}")
    given = [flag for flag, value in _ingest_options(args) if value is not None]
    if given and not args.video:
        raise InputError(f"{', '.join(given)} go with --video (they are used while ingesting)")
    if ingest is None:
        ingest = _ingest_plan(root, args)  # checks the project and the video before anything runs
    remembered = _recall(root)
    if args.preset:
        name, preset, why = f"morf-{args.preset}", args.preset, "given with --preset"
    elif remembered.get("preset"):
        name, preset, _ = _run_name(root, remembered["preset"])
        why = f"the last 'morf run' on this project chose it ({RUN_FILE})"
    else:
        name, preset, why = _run_name(root, None)
    holdout = args.holdout if args.holdout is not None else (
        remembered.get("holdout") if remembered.get("preset") == preset else None)
    fresh = ("train", str(root), "--preset", preset, "--name", name)
    if holdout is not None:
        fresh += ("--holdout", str(holdout))
    fit_preset = _fit_preset(preset)

    def fit_step():
        _remember(root, preset, holdout)  # the project exists from here on
        return fit_plan(root, fit_preset)

    steps = (Step("ingest", lambda: ingest), Step("fit", fit_step),
             Step("train", lambda: train_plan(root, name, fresh, holdout)),
             Step("export", lambda: export_plan(root, name)))
    return RunPlan(steps[:STAGES.index(args.until) + 1], name, preset, why, holdout)


def run(args) -> int:
    from morf.cli.main import main
    from morf.pipeline.chain import run_steps

    root = Path(args.project)
    plan = plan_run(args)
    print(f"training preset: {plan.preset} ({plan.why}){preset_hint(plan.preset)}")
    rc = run_steps(list(plan.steps), main, "run", again_command(args))
    if rc == 0 and args.until == "ingest":
        _remember(root, plan.preset, plan.holdout)
    if rc == 0:
        if args.until == "export":
            print(f"avatar ready in {root / 'avatar'} (run {plan.name}); animate it with: "
                  f"morf animate {shlex.quote(str(root))} --motion FILE --out video.mp4")
        else:
            print(f"stopped after {args.until} as asked; continue to the export with: "
                  f"morf run {shlex.quote(str(root))}")
    return rc


def again_command(args) -> str:
    """The command line that runs this ``morf run`` again, with every option the user gave,
    quoted for a shell: pasted after a failed stage, it continues (an existing project made from
    the same --video skips ingest)."""
    argv = ["morf", "run", str(args.project)]
    if args.video is not None:
        argv += ["--video", str(args.video)]
    if args.until != "export":
        argv += ["--until", args.until]
    if args.preset is not None:
        argv += ["--preset", args.preset]
    if args.holdout is not None:
        argv += ["--holdout", str(args.holdout)]
    return shlex.join(argv + _ingest_argv(args))


def _ingest_plan(root: Path, args):
    """Skip ingest for an existing project (made from this video, when one is given); refuse a
    project of another kind or source, and a folder that is not a project."""
    from morf.capture.project import CaptureProject
    from morf.errors import InputError
    from morf.pipeline.chain import Plan

    video = args.video
    if video is not None and not video.is_file():
        raise InputError(f"video not found: {video}" if not video.exists() else f"not a video file: {video}")
    if CaptureProject.is_project(root):
        project = CaptureProject.open(root)
        source = project.manifest.get("source") or {}
        kind = "synthetic" if project.is_synthetic else str(source.get("kind", "unknown"))
        if video is not None:
            if kind != "video":
                raise InputError(f"{root} is a {_kind_words(kind)}, not one made from a video; run "
                                 f"'morf run {root}' without --video to continue it, or choose a new folder")
            made_from = Path(str(source.get("path", "")))
            if made_from.resolve() != video.resolve():
                raise InputError(f"{root} was made from {made_from}, not {video}; run without --video to continue "
                                 f"it, or choose a new folder for {video.name}")
        what = f"from {Path(str(source.get('path'))).name}" if kind == "video" else f"of a {_kind_words(kind)}"
        return Plan("skip", note=f"{project.num_frames} frames {what}")
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise InputError(f"{root} exists and is not a MoRF capture project; choose a new folder")
    if video is None:
        raise InputError(f"{root} is not a capture project yet; give --video FILE to make one")
    return Plan("run", ("ingest", str(root), "--video", str(video), *_ingest_argv(args)))


def _ingest_options(args) -> list[tuple[str, object]]:
    """The ``morf ingest`` options given to ``morf run``, as (flag, value or None)."""
    return [("--keypoints", args.keypoints), ("--masks", args.masks), ("--every", args.every),
            ("--max-frames", args.max_frames), ("--resize", args.resize),
            ("--no-mirror-average", args.no_mirror_average or None)]


def _ingest_argv(args) -> list[str]:
    """The ``morf ingest`` options given to ``morf run``, as command-line words."""
    argv = []
    for flag, value in _ingest_options(args):
        if value is True:
            argv.append(flag)
        elif value is not None:
            argv += [flag, str(value)]
    return argv


def _recall(root: Path) -> dict:
    """The choices of the last ``morf run`` on this project (PROJECT/run.json), or {}."""
    import json

    try:
        d = json.loads((root / RUN_FILE).read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(d, dict):
        return {}
    preset = d.get("preset") if d.get("preset") in (*PRESETS["train"], "auto") else None
    holdout = d.get("holdout") if isinstance(d.get("holdout"), int) and d.get("holdout") >= 2 else None
    return {"preset": preset, "holdout": holdout}


def _remember(root: Path, preset: str, holdout: int | None) -> None:
    from morf.io import atomic_write_json

    if (root / RUN_FILE).is_file() and _recall(root) == {"preset": preset, "holdout": holdout}:
        return
    atomic_write_json(root / RUN_FILE, {"preset": preset, "holdout": holdout})


def _kind_words(kind: str) -> str:
    return {"synthetic": "synthetic capture (morf synth)", "images": "capture made from images",
            "image": "capture made from one image", "people-snapshot": "People-Snapshot capture",
            "zju-mocap": "ZJU-MoCap capture"}.get(kind, f"{kind} capture")


def _run_name(root: Path, preset: str | None) -> tuple[str, str, str]:
    """(run name, train preset, why that preset): ``morf-PRESET`` for a named preset; without one,
    the project's latest trained or started run (not an RGB floor), else the default preset's run."""
    from morf.presets import default_preset

    if preset:
        return f"morf-{preset}", preset, "asked for"
    latest = _latest_run(root)
    if latest is not None:
        return (*latest, f"the project's latest training run, {latest[0]}, used it")
    preset = default_preset("train")
    why = "CUDA is present" if preset == "gpu" else "no CUDA device: the few-minute CPU preset"
    return f"morf-{preset}", preset, why


def preset_hint(preset: str) -> str:
    """What to name instead for more detail, when a larger preset fits the same machine."""
    from morf.train.config import DETAIL_PRESET

    if preset == "cpu":
        return (f"; --preset {DETAIL_PRESET} trains the face and hands at the player's density, in about half "
                "an hour on 2 cores")
    return ""


def _latest_run(root: Path) -> tuple[str, str] | None:
    from morf.errors import MorfError
    from morf.train.run_dir import RunDir

    runs = root / "runs"
    found = []
    for d in runs.iterdir() if runs.is_dir() else ():
        run = RunDir(d)
        if d.name.startswith(".") or not run.config_path.is_file():
            continue
        try:
            cfg = run.load_config()
        except MorfError:
            continue
        if cfg.method == "rgb":
            continue
        stamp = max(p.stat().st_mtime for p in (run.config_path, run.checkpoint_path, run.avatar_path) if p.is_file())
        found.append((stamp, d.name, cfg.preset))
    if not found:
        return None
    _, name, preset = max(found)
    return name, preset


def _fit_preset(train_preset: str) -> str:
    """The fit preset that goes with a training size: the one of the same name (tiny, cpu, gpu:
    the names every stage has), else (auto) the default fit."""
    from morf.presets import PRESETS, default_preset

    return train_preset if train_preset in PRESETS["fit"] else default_preset("fit")
