"""``morf demo DIR``: the whole pipeline on a built-in synthetic capture.

synth (a person turning in place, with ground truth) -> fit -> train -> export (int8) -> animate a
motion -> DIR/animation.mp4. Every step is the same sub-command a user would run, chained as
``morf run`` chains them (:mod:`morf.pipeline.chain`); finished steps are skipped and a killed fit
or training run resumes, so running it again continues where it stopped.
"""

from __future__ import annotations

import shlex
import time
from pathlib import Path

from morf.errors import MorfError

DEMO_MOTION = "walk_forward.npz"  # of the motions shipped in the package (morf.resources.MOTIONS)
DEMO_FILES = ("capture", "animation.mp4")  # what a demo folder holds; the demo writes nothing else there


def add_parser(sub):
    from morf.presets import default_preset, presets_of

    p = sub.add_parser("demo", help="run the whole pipeline on a built-in synthetic capture")
    p.add_argument("dir", nargs="?", default="demo", help="demo folder (created; default ./demo)")
    default = default_preset("demo")  # the presets: morf/presets/demo.py
    p.add_argument("--preset", choices=tuple(presets_of("demo")), default=default,
                   help=f"how big a run: {' | '.join(presets_of('demo'))} (default {default})")
    p.add_argument("--motion", default=None, help=f"motion to animate, .bvh or AMASS .npz (default: {DEMO_MOTION}, "
                                                   "shipped with morf)")
    return p


def default_motion() -> Path:
    from morf.resources import MOTIONS

    path = MOTIONS / DEMO_MOTION
    if not path.is_file():
        raise MorfError(f"the shipped motion {path} is missing (a broken install?): pass --motion FILE (.bvh or "
                        "AMASS .npz)")
    return path


def check_demo_folder(root: Path) -> None:
    """The demo writes only into a new or empty folder, or one an earlier demo made (its capture
    project and video and nothing else); anything else is refused in one line."""
    from morf.capture.project import CaptureProject
    from morf.errors import InputError

    if root.exists() and not root.is_dir():
        raise InputError(f"{root} is not a folder; give a new folder name for the demo")
    if not root.is_dir():
        return
    other = sorted(p.name for p in root.iterdir() if p.name not in DEMO_FILES)
    capture = root / "capture"
    if capture.exists() and not (capture.is_dir() and (CaptureProject.is_project(capture) or not any(capture.iterdir()))):
        other.insert(0, "capture (not a capture project)")
    if other:
        raise InputError(f"{root} holds files the demo did not write ({', '.join(other[:3])}); give a new folder "
                         "name for the demo (e.g. morf demo demo-2)")


def run(args) -> int:
    from morf.capture.project import CaptureProject
    from morf.cli.main import main
    from morf.cli.project_steps import export_plan, fit_plan, train_plan
    from morf.pipeline.chain import Plan, Step, run_steps
    from morf.presets import preset as named_preset

    preset = named_preset("demo", args.preset)
    root = Path(args.dir)
    check_demo_folder(root)
    project = root / "capture"
    motion = Path(args.motion) if args.motion else default_motion()
    name = f"demo-{args.preset}"
    train = ("train", str(project), "--preset", preset.train, "--name", name)
    if preset.train_steps:
        train += ("--steps", str(preset.train_steps))
    train += preset.train_set_args()
    # --force: the demo folder is the demo's own (check_demo_folder), so its video is replaced on a re-run
    animate = ("animate", str(project), "--motion", str(motion), "--out", str(root / "animation.mp4"),
               "--size", str(preset.size), "--max-frames", str(preset.max_frames), "--camera", "follow", "--force")

    def synth() -> Plan:
        if CaptureProject.is_project(project):
            return Plan("skip")
        return Plan("run", ("synth", str(project), "--preset", preset.synth))

    steps = [
        Step("synthetic capture", synth),
        Step("body fits", lambda: fit_plan(project, preset.fit)),
        Step("avatar training", lambda: train_plan(project, name, train)),
        Step("int8 export", lambda: export_plan(project, name)),
        Step("animation", lambda: Plan("run", animate)),  # the motion may differ from the last run's
    ]
    t_all = time.perf_counter()
    rc = run_steps(steps, main, "demo", shlex.join(["morf", "demo", str(root)]))
    if rc != 0:
        return rc
    print(f"demo finished in {(time.perf_counter() - t_all) / 60:.1f} min: video {root / 'animation.mp4'}, "
          f"avatar {project / 'avatar'}; open the capture in the studio with: morf-studio {project}")
    web = root.absolute().parent / f"{root.absolute().name}-web"  # beside the demo folder, which holds only the demo's files
    print(f"play the avatar in a browser: morf web {shlex.quote(str(project / 'avatar'))} {shlex.quote(str(web))} "
          f"--force && morf serve {shlex.quote(str(web))}")
    return 0
