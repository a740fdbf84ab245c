"""``morf bench step --out DIR``: seconds per training step, with bfloat16 autocast on and off.

Whether bf16 pays depends on the CPU: native (AMX-BF16, AVX512-BF16) it is faster, emulated it was
1.8x slower. The trainer decides by itself (``morf/cpu_features.py``); this benchmark measures both
ways on the machine it runs on, forcing each, and records the CPU's flags beside the times.

Uses ``--project`` (its fits, else a synthetic capture's ground truth) or builds the default
synthetic capture in ``OUT/capture``. Writes ``DIR/step.json`` and ``DIR/step.md``.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

COLUMNS = ["bf16", "s_per_step", "chosen_by_trainer"]


@dataclass(frozen=True)
class StepTime:
    """One setting of ``morf bench step``.

    Fields:
        bf16: bfloat16 autocast on; s_per_step: mean seconds a training step;
        chosen_by_trainer: the setting the trainer picks by itself on this CPU.
    """

    bf16: bool
    s_per_step: float
    chosen_by_trainer: bool

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(d: dict) -> StepTime:
        return StepTime(d["bf16"], d["s_per_step"], d["chosen_by_trainer"])


@dataclass(frozen=True)
class StepResult:
    """``step.json``.

    Fields:
        preset, method: the timed training configuration; project: the capture project's folder;
        frames: its training frames; steps: timed steps a setting; rows: one StepTime a setting
        (bf16 on, then off); machine: :func:`morf.bench.common.machine_info`.
    """

    preset: str
    method: str
    project: str
    frames: int
    steps: int
    rows: tuple[StepTime, ...]
    machine: dict

    def to_dict(self) -> dict:
        return {"benchmark": "step", "preset": self.preset, "method": self.method, "project": self.project,
                "frames": self.frames, "steps": self.steps, "rows": [r.to_dict() for r in self.rows],
                "machine": self.machine}

    @staticmethod
    def from_dict(d: dict) -> StepResult:
        return StepResult(d["preset"], d["method"], d["project"], d["frames"], d["steps"],
                          tuple(StepTime.from_dict(r) for r in d["rows"]), d["machine"])


def add_arguments(p):
    from morf.presets import presets_of

    p.add_argument("--out", required=True, help="output folder for step.json / step.md")
    p.add_argument("--project", default=None, help="a capture project (default: build the default synthetic one)")
    p.add_argument("--preset", choices=tuple(presets_of("train")), default="cpu", help="training preset to time")
    p.add_argument("--method", choices=("morf", "stylepeople", "anr"), default="morf")
    p.add_argument("--steps", type=int, default=40, help="timed steps per setting")
    p.add_argument("--warmup", type=int, default=6, help="untimed steps first")


def _project(args, out: Path):
    from morf.capture.project import CaptureProject

    if args.project:
        return CaptureProject.open(args.project)
    root = out / "capture"
    if CaptureProject.is_project(root):
        return CaptureProject.open(root)
    from morf.synth.capture import make_synthetic_capture
    from morf.synth.config import synth_config

    name = "tiny" if args.preset == "tiny" else "default"
    return make_synthetic_capture(root, synth_config(name, detector="none"), overwrite=True)


def time_steps(trainer, steps: int, warmup: int) -> float:
    """Mean seconds per :meth:`Trainer.train_step` over ``steps`` after ``warmup`` untimed ones."""
    for _ in range(warmup):
        trainer.train_step()
    t0 = time.perf_counter()
    for _ in range(steps):
        trainer.train_step()
    return (time.perf_counter() - t0) / max(steps, 1)


def run(args) -> int:
    import torch

    from morf.bench.common import machine_info, markdown_table, write_results
    from morf.body import load_body_model
    from morf.errors import InputError
    from morf.train.config import preset
    from morf.train.data import build_frames
    from morf.train.trainer import Trainer

    if args.steps < 1 or args.warmup < 0:
        raise InputError("--steps must be at least 1 and --warmup at least 0")
    out = Path(args.out)
    model = load_body_model("anny")
    project = _project(args, out)
    cfg = preset(args.preset, args.method, device="cpu")
    frames = build_frames(project, model, cfg.resolution).frames
    zoom = build_frames(project, model, cfg.zoom_resolution).frames if cfg.zoom_resolution else None
    texture = torch.rand(cfg.texture_channels, cfg.texture_size, cfg.texture_size)
    rows, note = [], ""
    for bf16 in (True, False):
        trainer = Trainer(cfg, frames, texture, device="cpu", zoom_frames=zoom)
        chosen, note = trainer.bf16, trainer.bf16_note  # what a training here gets, and why
        trainer.bf16 = bf16  # forced either way: the point is to see what each costs here
        s = time_steps(trainer, args.steps, args.warmup)
        rows.append(StepTime(bf16, s, bf16 == chosen))
        print(f"bf16 autocast {'on ' if bf16 else 'off'}: {s:.3f} s/step")
    machine = machine_info()
    result = StepResult(args.preset, args.method, str(project.root), frames.num_frames, args.steps, tuple(rows),
                        machine)
    md = (f"# Training step time ({args.preset} preset, {args.method})\n\n"
          f"CPU: {machine['cpu']}; flags: {', '.join(machine['cpu_features']['flags']) or 'none read'}; "
          f"native bf16: {machine['cpu_features']['native_bf16']}; a training here: bfloat16 autocast {note}\n\n"
          + markdown_table([r.to_dict() for r in rows], COLUMNS, "{:.3f}"))
    path = write_results(out, "step", result.to_dict(), md)
    print(f"wrote {path}")
    return 0
