"""A capture project made from a video (or a folder of frames) in the studio's worker, as
``morf run PROJECT --video FILE`` makes it: ingest -> fit -> train -> export.

The steps are planned by the same functions ``morf run`` plans them with (:mod:`morf.cli.run`,
:mod:`morf.cli.project_steps`): a stage whose output is complete is skipped and a stopped one is
resumed, so starting the same project again continues where it stopped, in the studio or with
``morf run`` in a terminal. :func:`morf.pipeline.chain.run_steps` chains them. Each plan is a
``morf`` sub-command; :func:`stage_runner` runs it as the library call that sub-command makes, on
the calling thread (the worker), with the worker's :class:`StageControl` for progress, pause and
stop: no subprocess, and no signal handler (signals belong to the main thread).
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from morf.pipeline.chain import Plan, Step
from morf.pipeline.control import StageControl

STAGES = ("ingest", "fit", "train", "export")


@dataclass(frozen=True)
class PipelineRequest:
    """What to make: a project folder from a video (or frames), up to a stage, at a training size.

    Fields:
        root: the project folder (new, or a project made earlier from the same source).
        source: a video file or a folder of images; None: continue the existing project.
        until: the last stage to run (one of :data:`STAGES`).
        preset: the training size (``morf run --preset``); None: the one ``morf run`` picks.
    """

    root: str
    source: str | None = None
    until: str = "export"
    preset: str | None = None

    @property
    def frames(self) -> str | None:
        """The source when it is a folder of images (this looks at the disk: worker thread only)."""
        return self.source if self.source and Path(self.source).is_dir() else None

    def run_argv(self) -> list[str]:
        """The ``morf run`` command line that makes the same project (a folder of frames is left
        out, as ``morf run`` takes videos only: it continues the project once ingested)."""
        argv = ["run", self.root]
        if self.source and not self.frames:
            argv += ["--video", self.source]
        if self.until != "export":
            argv += ["--until", self.until]
        if self.preset:
            argv += ["--preset", self.preset]
        return argv

    def again_command(self) -> str:
        """What continues this run from a terminal, quoted for a shell."""
        return shlex.join(["morf", *self.run_argv()])


def plan_steps(request: PipelineRequest) -> list[Step]:
    """The steps ``morf run`` would take for ``request``, planned as it plans them (the project
    and the video are checked here, before anything runs: an :class:`InputError` otherwise)."""
    from morf.cli import run as morf_run
    from morf.cli.main import build_parser
    from morf.errors import InputError
    from morf.presets import PRESETS

    if not request.root.strip():
        raise InputError("choose a folder for the new project")
    if request.until not in STAGES:
        raise InputError(f"until must be one of {', '.join(STAGES)}, got {request.until!r}")
    if request.preset is not None and request.preset not in (*PRESETS["train"], "auto"):
        raise InputError(f"unknown training size {request.preset!r}; one of {', '.join((*PRESETS['train'], 'auto'))}")
    if request.source and not Path(request.source).exists():
        raise InputError(f"video not found: {request.source}")
    args = build_parser().parse_args(request.run_argv())
    frames = request.frames
    return list(morf_run.plan_run(args, _frames_plan(Path(args.project), frames) if frames else None).steps)


def _frames_plan(root: Path, frames: str) -> Plan:
    """Ingest a folder of frames into a new project; an existing project is continued as it is."""
    from morf.capture.project import CaptureProject
    from morf.errors import InputError

    if CaptureProject.is_project(root):
        return Plan("skip", note=f"{CaptureProject.open(root).num_frames} frames")
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise InputError(f"{root} exists and is not a MoRF capture project; choose a new folder")
    return Plan("run", ("ingest", str(root), "--frames", frames))


def stage_runner(control: StageControl, on_stage: Callable[[str], None] = lambda name: None
                 ) -> Callable[[list[str]], int]:
    """A ``command`` for :func:`run_steps`: runs one planned ``morf`` sub-command as its library
    call with ``control``; returns 0, or 130 when it stopped (user errors raise, as they do in the
    library). ``on_stage(name)`` is called as each starts."""
    from morf.cli.main import build_parser

    parser = build_parser()

    def command(argv: list[str]) -> int:
        args = parser.parse_args(argv)
        on_stage(args.command)
        RUNNERS[args.command](args, control)
        return 130 if control.stop_requested else 0

    return command


def _ingest(args, control: StageControl) -> None:
    from morf.capture.ingest import IngestConfig, ingest

    ingest(args.project, IngestConfig(video=args.video, frames=args.frames, keypoints=args.keypoints,
                                      masks=args.masks, max_frames=args.max_frames, every=args.every,
                                      resize=args.resize, fps=args.fps, focal=args.focal,
                                      frame_format=args.frame_format, force=args.force,
                                      mirror_average=args.mirror_average), control)


def _fit(args, control: StageControl) -> None:
    from morf.capture.project import CaptureProject
    from morf.cli.fit import resolve_config
    from morf.fitting.project_fit import fit_project

    cfg = resolve_config(args)
    device = None
    if args.device:
        import torch

        device = torch.device(args.device)
    fit_project(CaptureProject.open(args.project), cfg, focal=args.focal, restart=args.restart, control=control,
                device=device)


def _train(args, control: StageControl) -> None:
    from morf.capture.project import CaptureProject
    from morf.cli.train import resolve_config
    from morf.train.project_run import train_project

    project = CaptureProject.open(args.project)
    cfg, _ = resolve_config(args, project)
    train_project(project, cfg, args.name, control, args.fits, args.vgg, args.restart)


def _export(args, control: StageControl) -> None:
    from morf.capture.project import CaptureProject
    from morf.export.project_export import ProjectExportConfig, export_project

    cfg = ProjectExportConfig(run=args.run, out=args.out, input_layout=args.layout,
                              calibration_views=args.calibration_views, fits=args.fits, force=args.force)
    export_project(CaptureProject.open(args.project), cfg, control)


# the sub-commands the plans name -> their library calls (the morf/cli module's run() without its
# printing and signal handler)
RUNNERS: dict[str, Callable] = {"ingest": _ingest, "fit": _fit, "train": _train, "export": _export}
