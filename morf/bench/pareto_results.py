"""What ``morf bench pareto`` writes, as typed results: one sweep point's row (``OUT/points/<name>.json``
as measured, and its row in ``pareto.json``'s "points" with what the whole sweep adds), and
``pareto.json``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from morf.bench.train_eval import RunSpeed, TrainEvaluation

QUALITY = "psnr_person"  # the fronts' quality axis: what the renderer gets right on the person
PAPER_NOTE = ("Paper (MoRF, WACV 2024): 640x640 at 30 fps on a Snapdragon 888 phone GPU, ~14.4M-parameter U-Net; "
              "SSIM 0.899 / LPIPS 0.0623 / tLPIPS 0.00466 on their real captures. Only the fps target is comparable: "
              "quality here is measured on a synthetic capture, and fps on this machine's CPU.")


@dataclass(frozen=True)
class PointRow:
    """One sweep point's result.

    Fields:
        name, axis, precision: the SweepPoint's; method: its training config's; key: what a saved
            result must match to be reused (training config, precision, fps size); config: the
            training config's summary (renderer, texture, resolution, steps, method);
        evaluation: its training scored on the hold-out (shared by the int8 and fp32 points of a model);
        speed: playback at the sweep's fps size (None: not measured, the training diverged);
        seconds: its training's and its measurement's wall time;
        seed_runs, seed_means: with several seeds, each of :data:`morf.bench.pareto.SEED_KEYS` over
            the trainings (this one first) and its mean; on_front_fps, on_front_train: on the fronts.
            These four are the sweep's, not the point file's: None there, and left out of :meth:`to_dict`.
    """

    name: str
    axis: str
    method: str
    precision: str
    key: str
    config: dict
    evaluation: TrainEvaluation
    speed: RunSpeed | None
    seconds: float
    seed_runs: dict[str, list] | None = None
    seed_means: dict[str, float | None] | None = None
    on_front_fps: bool | None = None
    on_front_train: bool | None = None

    @property
    def fps(self) -> float | None:
        return None if self.speed is None else self.speed.playback.fps

    def metric(self, key: str) -> float | None:
        """This training's ``fps``, or a hold-out or training figure of :class:`TrainEvaluation` by name."""
        return self.fps if key == "fps" else getattr(self.evaluation, key)

    def mean(self, key: str) -> float | None:
        """:meth:`metric`, as the mean over the seeds when the point was trained with several."""
        return self.seed_means[key] if self.seed_means is not None else self.metric(key)

    def to_dict(self) -> dict:
        d = {"name": self.name, "axis": self.axis, "method": self.method, "precision": self.precision,
             "key": self.key, "config": self.config, **self.evaluation.to_dict()}
        if self.speed is None:
            d.update(fps=None, frame_ms=None, renderer_ms=None, int8_psnr_vs_fp32_db=None)
        else:
            p = self.speed.playback
            d.update(fps=p.fps, frame_ms=p.frame_ms, renderer_ms=p.renderer_ms,
                     int8_psnr_vs_fp32_db=self.speed.int8_psnr_vs_fp32_db)
            if p.int8_psnr_vs_fp32_image_db is not None:
                d["int8_psnr_vs_fp32_image_db"] = p.int8_psnr_vs_fp32_image_db
        d["seconds"] = self.seconds
        extra = {"seed_runs": self.seed_runs, "seed_means": self.seed_means, "on_front_fps": self.on_front_fps,
                 "on_front_train": self.on_front_train}
        d.update({k: v for k, v in extra.items() if v is not None})
        return d

    @staticmethod
    def from_dict(d: dict) -> PointRow:
        return PointRow(d["name"], d["axis"], d["method"], d["precision"], d["key"], d["config"],
                        TrainEvaluation.from_dict(d), None if d["fps"] is None else RunSpeed.from_dict(d),
                        d["seconds"], d.get("seed_runs"), d.get("seed_means"), d.get("on_front_fps"),
                        d.get("on_front_train"))


@dataclass(frozen=True)
class FloorPoint:
    """The RGB floor (no learning) on the base point's frames, scored as the points are
    (:func:`morf.bench.pareto.floor_point`); its playback speed is not measured (it cannot be exported).

    Fields:
        run: its run folder; psnr_person, psnr: hold-out PSNR over the person and the image, dB;
        ssim_person: hold-out SSIM over the person; temporal: flicker (lower is better; NaN with
        fewer than two frames). The same for every floor: name "rgb floor", fps None (not measured).
    """

    run: str
    psnr_person: float | None
    ssim_person: float | None
    psnr: float | None
    temporal: float

    name: ClassVar[str] = "rgb floor"
    fps: ClassVar[None] = None

    def metric(self, key: str) -> float | None:
        """A hold-out figure by name (``fps`` is None), as :meth:`PointRow.metric`."""
        return getattr(self, key)

    def to_dict(self) -> dict:
        return {"name": self.name, "run": self.run, "fps": self.fps, "psnr_person": self.psnr_person,
                "ssim_person": self.ssim_person, "psnr": self.psnr, "temporal": self.temporal}

    @staticmethod
    def from_dict(d: dict) -> FloorPoint:
        return FloorPoint(d["run"], d["psnr_person"], d["ssim_person"], d["psnr"], d["temporal"])


@dataclass(frozen=True)
class SweepResult:
    """``pareto.json``.

    Fields:
        preset, scene: the sweep preset and the capture's scene; project: the capture's folder;
        fps_size: playback is timed at fps_size^2; points: every point's row, fronts marked;
        seed_spread: :func:`morf.bench.pareto.seed_spread` (None without seed points); reused: the
        points loaded from ``OUT/points`` unmeasured; seeds: trainings per point; floor: the RGB
        floor (:func:`morf.bench.pareto.floor_point`); ray: {"address", "cpus_per_task"} of the trainings;
        machine: :func:`morf.bench.common.machine_info`; charts: the PNGs written.
    """

    preset: str
    scene: str
    project: str
    fps_size: int
    points: tuple[PointRow, ...]
    seed_spread: dict | None
    reused: tuple[str, ...]
    seeds: int
    floor: FloorPoint
    ray: dict
    machine: dict
    charts: tuple[str, ...]

    @property
    def front_fps(self) -> list[str]:
        return [p.name for p in self.points if p.on_front_fps]

    @property
    def front_train(self) -> list[str]:
        return [p.name for p in self.points if p.on_front_train]

    def to_dict(self) -> dict:
        return {"benchmark": "pareto", "preset": self.preset, "scene": self.scene, "project": self.project,
                "quality_metric": QUALITY, "fps_size": self.fps_size, "fps_precision_default": "int8",
                "points": [p.to_dict() for p in self.points], "front_fps": self.front_fps,
                "front_train": self.front_train, "seed_spread": self.seed_spread, "reused": list(self.reused),
                "seeds": self.seeds, "floor": self.floor.to_dict(), "ray": self.ray,
                "paper_reference": {"fps": 30, "size": 640, "device": "Snapdragon 888", "params_m": 14.4,
                                    "ssim": 0.899, "lpips": 0.0623, "tlpips": 0.00466, "comparable": ["fps"],
                                    "note": PAPER_NOTE},
                "machine": self.machine, "charts": list(self.charts)}
