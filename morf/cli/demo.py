"""``morf demo DIR``: the whole pipeline on a built-in synthetic capture.

synth (a person turning in place, with ground truth) -> fit -> train -> export (int8) -> animate a
motion -> DIR/animation.mp4. Every step is the same sub-command a user would run, chained as
``morf run`` chains them (:mod:`morf.pipeline.chain`); finished steps are skipped and a killed fit
or training run resumes, so running it again continues where it stopped.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from morf.errors import MorfError

REPO = Path(__file__).resolve().parents[2]
CMU_BVH = REPO.parent / "shared" / "data" / "motion" / "cmu" / "01_01.bvh"
SAMPLE_MOTIONS = REPO / "resources" / "motions"


@dataclass(frozen=True)
class DemoPreset:
    synth: str  # morf synth preset
    fit: str  # morf fit preset
    train: str  # morf train preset
    train_steps: int | None  # override of the preset's steps (None: the preset's own)
    size: int  # output video size in pixels
    max_frames: int  # frames of the motion to render (0: all)


PRESETS = {
    # Seconds: what CI runs.
    "tiny": DemoPreset("tiny", "fast", "tiny", None, 128, 8),
    # Under ten minutes on 2 CPU cores: a default-size capture, a shortened cpu-preset training (the
    # colour starts from the projected frames, so a few hundred steps already look like the person;
    # the stem x4 renderer affords 1000 of the preset's 1500 in about the time 600 took at stem x2).
    "quick": DemoPreset("default", "default", "cpu", 1000, 640, 240),
    # The cpu preset trained to its plateau (tens of minutes).
    "full": DemoPreset("default", "default", "cpu", None, 640, 0),
}


def add_parser(sub):
    p = sub.add_parser("demo", help="run the whole pipeline on a built-in synthetic capture")
    p.add_argument("dir", nargs="?", default="demo", help="demo folder (created; default ./demo)")
    p.add_argument("--preset", choices=sorted(PRESETS), default="quick", help="how big a run (default quick)")
    p.add_argument("--motion", default=None, help="motion to animate (default: CMU 01_01.bvh if present, else a "
                                                   "motion shipped in resources/motions)")
    return p


def default_motion() -> Path:
    if CMU_BVH.is_file():
        return CMU_BVH
    shipped = sorted(SAMPLE_MOTIONS.glob("*.npz")) + sorted(SAMPLE_MOTIONS.glob("*.bvh"))
    if not shipped:
        raise MorfError("no motion to animate: pass --motion FILE (.bvh or AMASS .npz)")
    return shipped[0]


def run(args) -> int:
    from morf.capture.project import CaptureProject
    from morf.cli.main import main
    from morf.cli.project_steps import export_plan, fit_plan, train_plan
    from morf.pipeline.chain import Plan, Step, run_steps

    preset = PRESETS[args.preset]
    root = Path(args.dir)
    project = root / "capture"
    motion = Path(args.motion) if args.motion else default_motion()
    name = f"demo-{args.preset}"
    train = ("train", str(project), "--preset", preset.train, "--name", name)
    if preset.train_steps:
        train += ("--steps", str(preset.train_steps))
    animate = ("animate", str(project), "--motion", str(motion), "--out", str(root / "animation.mp4"),
               "--size", str(preset.size), "--max-frames", str(preset.max_frames), "--camera", "follow")

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
    rc = run_steps(steps, main, "demo", f"morf demo {root}")
    if rc != 0:
        return rc
    print(f"demo finished in {(time.perf_counter() - t_all) / 60:.1f} min: video {root / 'animation.mp4'}, "
          f"avatar {project / 'avatar'}; open the capture in the studio with: morf-studio {project}")
    return 0
