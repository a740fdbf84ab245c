"""What ``morf eval`` writes, as typed results (:func:`morf.evaluate.project_eval.evaluate_project`):
one run's scores on one target, one run's entry, one target's entry (its images), and ``eval.json``.
Torch-free, so a reader of ``eval.json`` needs no model."""

from __future__ import annotations

import math
from dataclasses import dataclass


def _finite(v: float | None) -> float | None:
    """None for NaN and infinities (eval.json holds null there)."""
    return None if isinstance(v, float) and not math.isfinite(v) else v


@dataclass(frozen=True)
class TargetScores:
    """One run's scores on one target, rendered and real frames both over the capture's backdrop colour.

    Fields:
        psnr (dB), ssim: over the whole image; psnr_person (dB), ssim_person: over the person (the
            ground-truth mask); each the mean over the frames (None: no finite value);
        temporal: flicker over consecutive frames (None with fewer than two frames);
        background: the colour (r, g, b) in [0, 1]; frames: the frames scored;
        lpips, lpips_person: LPIPS over the image and the person (None: not computed);
        resolution: the evaluation side in pixels;
        trained_on: capture targets only, how many of these frames the run trained on (None for the
            novel poses; then left out of :meth:`to_dict`);
        refined_l1: with refined poses, the mean L1 of the composited render before and after the
            refinement (None: the poses were scored as given; then left out of :meth:`to_dict`);
        detail: the region scores at native size, ``{"<group>_<score>": value}`` for the groups
            person, head, hands and the scores psnr, ssim_shift, gmsd, hf_ratio, hf_ratio_inside, count
            (:mod:`morf.evaluate.detail_eval`), plus ``resolution`` and ``max_shift`` (None: not
            scored; then left out of :meth:`to_dict`);
        mask_iou: mean IoU of the rendered mask (probability > 0.5) and the real person mask
            (:mod:`morf.evaluate.silhouette`; None: not scored, then left out of :meth:`to_dict`);
        warp_flicker, warp_flicker_real: the temporal warping error of the render and of the real
            frames (:mod:`morf.avatar.warp_flicker`: flicker that forgives a steady misregistration;
            the real frames' own for scale); None: not scored, then left out.
    """

    psnr: float | None
    ssim: float | None
    psnr_person: float | None
    ssim_person: float | None
    temporal: float | None
    background: tuple[float, ...]
    frames: int
    lpips: float | None
    lpips_person: float | None
    resolution: int
    trained_on: int | None = None
    refined_l1: tuple[float, float] | None = None
    detail: dict | None = None
    mask_iou: float | None = None
    warp_flicker: float | None = None
    warp_flicker_real: float | None = None

    @staticmethod
    def of(scores, lpips: dict | None, resolution: int, trained_on: int | None = None,
           refined_l1: tuple[float, float] | None = None, detail: dict | None = None,
           mask_iou: float | None = None) -> TargetScores:
        """From a :class:`morf.train.frame_scores.FrameScores` (non-finite values become None) and
        :func:`morf.evaluate.perceptual.lpips_scores` (None: not computed)."""
        lp = lpips or {}
        return TargetScores(_finite(scores.psnr), _finite(scores.ssim), _finite(scores.psnr_person),
                            _finite(scores.ssim_person), _finite(scores.temporal), tuple(scores.background),
                            scores.frames, lp.get("lpips"), lp.get("lpips_person"), resolution, trained_on,
                            None if refined_l1 is None else tuple(refined_l1),
                            None if detail is None else {k: _finite(v) for k, v in detail.items()},
                            None if mask_iou is None else _finite(float(mask_iou)),
                            *((None, None) if scores.warp_flicker is None
                              else (_finite(scores.warp_flicker[0]), _finite(scores.warp_flicker[1]))))

    def metric(self, key: str) -> float | None:
        """A score by name (psnr, psnr_person, ssim, ssim_person, temporal, lpips, lpips_person, or
        a detail score such as head_ssim_shift; None where it was not scored)."""
        if key in self.__dataclass_fields__:
            return getattr(self, key)
        return None if self.detail is None else self.detail.get(key)

    def to_dict(self) -> dict:
        d = {"psnr": self.psnr, "ssim": self.ssim, "psnr_person": self.psnr_person, "ssim_person": self.ssim_person,
             "temporal": self.temporal, "background": list(self.background), "frames": self.frames,
             "lpips": self.lpips, "lpips_person": self.lpips_person, "resolution": self.resolution}
        if self.trained_on is not None:
            d["trained_on"] = self.trained_on
        if self.refined_l1 is not None:
            d["refined_l1"] = list(self.refined_l1)
        if self.detail is not None:
            d["detail"] = dict(self.detail)
        if self.mask_iou is not None:
            d["mask_iou"] = self.mask_iou
        if self.warp_flicker is not None:
            d["warp_flicker"], d["warp_flicker_real"] = self.warp_flicker, self.warp_flicker_real
        return d

    @staticmethod
    def from_dict(d: dict) -> TargetScores:
        return TargetScores(d["psnr"], d["ssim"], d["psnr_person"], d["ssim_person"], d["temporal"],
                            tuple(d["background"]), d["frames"], d["lpips"], d["lpips_person"], d["resolution"],
                            d.get("trained_on"), None if d.get("refined_l1") is None else tuple(d["refined_l1"]),
                            d.get("detail"), d.get("mask_iou"), d.get("warp_flicker"), d.get("warp_flicker_real"))


@dataclass(frozen=True)
class RunScores:
    """One run's entry.

    Fields:
        method: its training method (rgb: the floor); holdout: its hold-out setting K;
        train_resolution: its training side in pixels; fits: the fits it trained on
        ("fits" | "ground-truth" | "auto"); floor: whether it is an RGB floor;
        targets: target key -> TargetScores, for the targets it was scored on.
    """

    method: str
    holdout: int
    train_resolution: int
    fits: str
    floor: bool
    targets: dict[str, TargetScores]

    def to_dict(self) -> dict:
        return {"method": self.method, "holdout": self.holdout, "train_resolution": self.train_resolution,
                "fits": self.fits, "floor": self.floor, "targets": {k: t.to_dict() for k, t in self.targets.items()}}

    @staticmethod
    def from_dict(d: dict) -> RunScores:
        return RunScores(d["method"], d["holdout"], d["train_resolution"], d["fits"], d["floor"],
                         {k: TargetScores.from_dict(t) for k, t in d["targets"].items()})


@dataclass(frozen=True)
class TargetEntry:
    """One target's entry: its frames and the images written for it.

    Fields:
        title: a human description; holdout: the K whose runs it scores (None: every run);
        frame_ids: project frame numbers (capture) or hold-out sequence indices; sheet_frames: the
            frame_ids on the comparison sheet's rows; columns: the sheet's columns ("real", then the
            runs, floors last); slice_column: the y-t slices' image column, a fraction of the width;
        sheet, slices: the image files (in the output folder); sheet_size, slices_size: their
            (width, height) in pixels;
        heads, heads_size: the enlarged head crops of the sheet's rows (real | each run | floor)
            and its size (None: no head was scored; then left out of :meth:`to_dict`);
        reference: a capture hold-out's detail scores of the nearest seen frame copied in place of
            a render, ``{"name", "frames": the copied frame per held-out frame, "detail": {...}}``
            (:mod:`morf.evaluate.reference`; None: none, then left out of :meth:`to_dict`).
    """

    title: str
    holdout: int | None
    frame_ids: tuple[int, ...]
    sheet_frames: tuple[int, ...]
    columns: tuple[str, ...]
    slice_column: float
    sheet: str
    sheet_size: tuple[int, int]
    slices: str
    slices_size: tuple[int, int]
    heads: str | None = None
    heads_size: tuple[int, int] | None = None
    reference: dict | None = None

    def to_dict(self) -> dict:
        d = {"title": self.title, "holdout": self.holdout, "frame_ids": list(self.frame_ids),
             "sheet_frames": list(self.sheet_frames), "columns": list(self.columns),
             "slice_column": self.slice_column, "sheet": self.sheet, "sheet_size": list(self.sheet_size),
             "slices": self.slices, "slices_size": list(self.slices_size)}
        if self.heads is not None:
            d["heads"], d["heads_size"] = self.heads, list(self.heads_size)
        if self.reference is not None:
            d["reference"] = self.reference
        return d

    @staticmethod
    def from_dict(d: dict) -> TargetEntry:
        return TargetEntry(d["title"], d["holdout"], tuple(d["frame_ids"]), tuple(d["sheet_frames"]),
                           tuple(d["columns"]), d["slice_column"], d["sheet"], tuple(d["sheet_size"]), d["slices"],
                           tuple(d["slices_size"]), d.get("heads"),
                           None if d.get("heads_size") is None else tuple(d["heads_size"]), d.get("reference"))


@dataclass(frozen=True)
class EvalResult:
    """``eval.json``.

    Fields:
        project: the capture's folder (absolute); resolution: the evaluation side asked for
            ("training": each run's, "native", or pixels); lpips: what LPIPS was computed from, or why
            it was not (:func:`morf.evaluate.project_eval.lpips_note`);
        runs: run name -> RunScores; skipped: run name -> why it was not scored;
        targets: target key -> TargetEntry, capture frames first;
        poses: "given" (the fits, or the hold-out sequence's poses placed on the fitted body) or
            "refined" (each run's poses refined against the frames, ``morf eval --refine-poses``).
    """

    project: str
    resolution: int | str
    lpips: str
    runs: dict[str, RunScores]
    skipped: dict[str, str]
    targets: dict[str, TargetEntry]
    poses: str = "given"

    def scores(self, run: str, key: str) -> TargetScores | None:
        """The scores of ``run`` on target ``key`` (None: not scored there)."""
        entry = self.runs.get(run)
        return None if entry is None else entry.targets.get(key)

    def scored_runs(self, key: str) -> list[str]:
        """The runs scored on target ``key``, the floors last (the sheet's order)."""
        scored = [(n, e.floor) for n, e in self.runs.items() if key in e.targets]
        return [n for n, floor in scored if not floor] + [n for n, floor in scored if floor]

    def to_dict(self) -> dict:
        return {"project": self.project, "resolution": self.resolution, "lpips": self.lpips,
                "runs": {n: e.to_dict() for n, e in self.runs.items()}, "skipped": dict(self.skipped),
                "targets": {k: t.to_dict() for k, t in self.targets.items()}, "poses": self.poses}

    @staticmethod
    def from_dict(d: dict) -> EvalResult:
        return EvalResult(d["project"], d["resolution"], d["lpips"],
                          {n: RunScores.from_dict(e) for n, e in d["runs"].items()}, dict(d["skipped"]),
                          {k: TargetEntry.from_dict(t) for k, t in d["targets"].items()}, d.get("poses", "given"))
