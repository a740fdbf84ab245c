"""``morf bench step --out DIR``: seconds per training step, with bfloat16 autocast on and off.

Whether bf16 pays depends on the CPU: native (AMX-BF16, AVX512-BF16) it is faster, emulated it was
1.8x slower. The trainer decides by itself (:mod:`morf.machine.features`); this benchmark measures both
ways on the machine it runs on, forcing each, and records the CPU's flags beside the times.

Uses ``--project`` (its fits, else a synthetic capture's ground truth) or builds the default
synthetic capture in ``OUT/capture``. Writes ``DIR/step.json`` and ``DIR/step.md``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from morf.bench.records import FlatRecord

COLUMNS = ["bf16", "s_per_step", "chosen_by_trainer"]


@dataclass(frozen=True)
class StepTime(FlatRecord):
    """One setting of ``morf bench step``.

    Fields:
        bf16: bfloat16 autocast on; s_per_step: mean seconds a training step;
        chosen_by_trainer: the setting the trainer picks by itself on this CPU.
    """

    bf16: bool
    s_per_step: float
    chosen_by_trainer: bool


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


@dataclass(frozen=True)
class StepOptions:
    """What ``morf bench step`` times.

    Fields:
        out: folder for step.json / step.md; project: a capture project (None: the default
        synthetic one, made in ``OUT/capture``); preset, method: the training configuration timed;
        steps: timed steps a setting; warmup: untimed steps first.
    """

    out: str
    project: str | None = None
    preset: str = "cpu"
    method: str = "morf"
    steps: int = 40
    warmup: int = 6


def _project(opts: StepOptions, out: Path):
    from morf.capture.project import CaptureProject

    if opts.project:
        return CaptureProject.open(opts.project)
    root = out / "capture"
    if CaptureProject.is_project(root):
        return CaptureProject.open(root)
    from morf.synth.capture import make_synthetic_capture
    from morf.synth.config import synth_config

    name = "tiny" if opts.preset == "tiny" else "default"
    return make_synthetic_capture(root, synth_config(name, detector="none"), overwrite=True)


def time_steps(trainer, steps: int, warmup: int) -> float:
    """Mean seconds per :meth:`Trainer.train_step` over ``steps`` after ``warmup`` untimed ones."""
    for _ in range(warmup):
        trainer.train_step()
    t0 = time.perf_counter()
    for _ in range(steps):
        trainer.train_step()
    return (time.perf_counter() - t0) / max(steps, 1)


def run_step(opts: StepOptions) -> StepResult:
    """Time training steps with bfloat16 autocast forced on, then off; writes step.json and step.md."""
    import torch

    from morf.bench.common import machine_info, markdown_table, write_results
    from morf.body import load_body_model
    from morf.errors import InputError
    from morf.train.config import preset
    from morf.train.data import build_frames
    from morf.train.trainer import Trainer

    if opts.steps < 1 or opts.warmup < 0:
        raise InputError("--steps must be at least 1 and --warmup at least 0")
    out = Path(opts.out)
    model = load_body_model("anny")
    project = _project(opts, out)
    cfg = preset(opts.preset, opts.method, device="cpu")
    frames = build_frames(project, model, cfg.resolution).frames
    zoom = build_frames(project, model, cfg.zoom_resolution).frames if cfg.zoom_resolution else None
    texture = torch.rand(cfg.texture_channels, cfg.texture_size, cfg.texture_size)
    rows, note = [], ""
    for bf16 in (True, False):
        trainer = Trainer(cfg, frames, texture, device="cpu", zoom_frames=zoom)
        chosen, note = trainer.bf16, trainer.bf16_note  # what a training here gets, and why
        trainer.bf16 = bf16  # forced either way: the point is to see what each costs here
        s = time_steps(trainer, opts.steps, opts.warmup)
        rows.append(StepTime(bf16, s, bf16 == chosen))
        print(f"bf16 autocast {'on ' if bf16 else 'off'}: {s:.3f} s/step")
    machine = machine_info()
    result = StepResult(opts.preset, opts.method, str(project.root), frames.num_frames, opts.steps, tuple(rows),
                        machine)
    md = (f"# Training step time ({opts.preset} preset, {opts.method})\n\n"
          f"CPU: {machine['cpu']}; flags: {', '.join(machine['cpu_features']['flags']) or 'none read'}; "
          f"native bf16: {machine['cpu_features']['native_bf16']}; a training here: bfloat16 autocast {note}\n\n"
          + markdown_table([r.to_dict() for r in rows], COLUMNS, "{:.3f}"))
    path = write_results(out, "step", result.to_dict(), md)
    print(f"wrote {path}")
    return result
