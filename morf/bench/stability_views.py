"""The "views" series of ``morf bench stability``: the turn captured in a few views, fitted only.

Where the other series train avatars, this one stops at the fit, the stage that broke on sparse
captures: the default synthetic capture's turn kept as 8, 12, 16 and 24 views (45 ... 15 degrees
apart, with the times they had in the clip), with MediaPipe's keypoints and with the true
keypoints plus noise, each fitted as ``morf fit`` does (the preset's fit preset) and scored against
the truth:

* root error: angle between the fitted and the true body orientation, degrees (mean and worst);
* twist: the fitted body's pelvis-shoulder twist (``morf.fitting.twist``), degrees (worst), and
  the frames twisted past the frame filter's limit, with how many of them the filter caught;
* vertex error: mean per-vertex error after aligning the root joint, mm.

The whole capture fitted the same way is the reference ("dense"). Captures are made under
``OUT/captures/views-<keypoints>-<views>``; each score is kept in ``OUT/points/`` and reused.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from morf.presets.stability import ViewsSeries

LABEL = "views of the turn"


def _name(kind: str, views: int) -> str:
    return f"views-{kind}-{views if views else 'dense'}"


def _capture(out: Path, kind: str, views: int, vs: ViewsSeries, model):
    from morf.capture.project import CaptureProject
    from morf.synth import make_synthetic_capture, synth_config
    from morf.synth.ground_truth import has_ground_truth

    root = out / "captures" / _name(kind, views)
    if CaptureProject.is_project(root) and has_ground_truth(root):
        return CaptureProject.open(root)
    preset, overrides = vs.synth
    detector = "mediapipe" if kind == "mediapipe" else "none"
    cfg = synth_config(preset, **{**overrides, "views": views, "detector": detector})
    print(f"making capture {root.name}")
    return make_synthetic_capture(root, cfg, model=model, overwrite=True)


def score_fit(model, project, fits, rejected: dict[int, str], twist_limit: float) -> dict:
    """Root, twist and vertex error of ``fits`` against the project's ground truth."""
    from morf.bench.fitting import _vertices, root_error_deg
    from morf.synth.ground_truth import load_ground_truth

    gt = load_ground_truth(project)
    root = root_error_deg(fits.rotvecs, gt.rotvecs)
    verts, roots = _vertices(model, fits.rotvecs, fits.transl, fits.shape)
    gt_verts, gt_roots = _vertices(model, gt.rotvecs, gt.transl, gt.shape)
    vert = np.linalg.norm((verts - roots[:, None]) - (gt_verts - gt_roots[:, None]), axis=-1).mean(1) * 1000
    twisted = np.flatnonzero(fits.twist_deg > twist_limit)
    return {"frames": int(len(root)), "root_error_deg": float(root.mean()), "root_error_max_deg": float(root.max()),
            "twist_max_deg": float(fits.twist_deg.max()), "twisted_frames": int(len(twisted)),
            "twisted_caught": int(sum(int(i) in rejected for i in twisted)),
            "vertex_error_mm": float(vert.mean()), "rejected": len(rejected)}


def _point(out: Path, kind: str, views: int, vs: ViewsSeries, model) -> dict:
    """One (keypoints, views) score, fitted and saved unless already in ``OUT/points/``."""
    from morf.io import atomic_write_json
    from morf.presets import preset as named_preset

    path = out / "points" / f"{_name(kind, views)}.json"
    if path.is_file():
        return json.loads(path.read_text())
    from morf.fitting.project_fit import fit_project

    project = _capture(out, kind, views, vs, model)
    cfg = named_preset("fit", vs.fit).replace(overlays=False)
    print(f"fitting {project.root.name}")
    report = fit_project(project, cfg, model=model, restart=True)
    row = {"keypoints": kind, "views": views or "dense", "fit_seconds": report.seconds,
           **score_fit(model, project, report.fits, report.rejected, cfg.filter.max_twist_deg)}
    atomic_write_json(path, row)
    return row


def run_views(out: Path, vs: ViewsSeries, model) -> dict:
    """Fit and score every (keypoints, views) of the series: {"levels", "label", "rows": {kind: [row per
    level]}, "dense": {kind: row}}."""
    rows = {kind: [_point(out, kind, v, vs, model) for v in vs.levels] for kind in vs.keypoints}
    dense = {kind: _point(out, kind, 0, vs, model) for kind in vs.keypoints} if vs.dense else {}
    return {"label": LABEL, "levels": list(vs.levels), "fit_preset": vs.fit, "rows": rows, "dense": dense}


PANELS = (("root_error_deg", "root error (deg)"), ("twist_max_deg", "worst pelvis-shoulder twist (deg)"),
          ("vertex_error_mm", "vertex error (mm)"))


def views_chart(result: dict, path: Path, title: str) -> Path:
    """Three panels (root error, worst twist, vertex error) against the views kept, one line per
    keypoint kind; the dense capture's value as a dashed line of the same colour."""
    from morf.bench.charts import _pyplot, save_figure

    plt = _pyplot()
    fig, axes = plt.subplots(1, len(PANELS), figsize=(4.2 * len(PANELS), 3.3), dpi=100, squeeze=False)
    levels = np.asarray(result["levels"], float)
    for ax, (metric, label) in zip(axes[0], PANELS):
        for k, (kind, rows) in enumerate(result["rows"].items()):
            colour = f"C{k}"
            ax.plot(levels, [r[metric] for r in rows], "o-", c=colour, ms=4, label=kind)
            if kind in result["dense"]:
                ax.axhline(result["dense"][kind][metric], ls="--", c=colour, lw=1,
                           label=f"{kind}, every frame ({result['dense'][kind]['frames']})")
        ax.set_xlabel(result["label"], fontsize=8)
        ax.set_ylabel(label, fontsize=8)
        ax.set_xticks(levels)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    axes[0][0].legend(fontsize=7)
    return save_figure(fig, path, title)


def views_table_rows(result: dict) -> list[dict]:
    """The series as Markdown rows, the dense references last."""
    rows = [r for kind in result["rows"] for r in result["rows"][kind]]
    return rows + list(result["dense"].values())


COLUMNS = ["keypoints", "views", "root_error_deg", "root_error_max_deg", "twist_max_deg", "twisted_frames",
           "twisted_caught", "vertex_error_mm", "rejected", "fit_seconds"]
