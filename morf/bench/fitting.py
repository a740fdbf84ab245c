"""``morf bench fitting --out DIR``: mesh fitting against ground truth, with the paper's ablation.

On a synthetic capture (made in DIR/capture unless ``--project`` names one), each configuration
is fitted from scratch and compared with the true poses:

* baseline: SMPLify-style (robust keypoints + joint-limit prior, per-frame shapes);
* shared_shape, frame_filter, temporal, silhouette: the baseline plus that one refinement
  (as the paper's ablation table compares each against the baseline);
* all: every refinement.

Metrics per configuration: vertex_error_mm (mean per-vertex error after aligning the root
joint, over the frames kept for training), root_error_deg (mean angle between the fitted and the
true body orientation, frames kept), keypoint_error_px (fitted vs true, noise-free
keypoints), silhouette_iou (of the fitted surface, body plus clothing offsets, vs the dressed
person's mask), silhouette_iou_body (the body alone), jitter (mean vertex acceleration,
mm / frame^2, over the whole sequence), jitter_reduction (share below the baseline),
filter_precision / filter_recall (rejected vs corrupted frames), frames_per_second (fit +
evaluation wall time). ``--command-runs N`` also times the whole ``morf fit`` command in a fresh
process (start-up, evaluation and overlays counted), as a user runs it.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from morf.bench.common import machine_info, markdown_table, write_results

ABLATION = {
    "baseline": {},
    "shared_shape": {"shared_shape": True},
    "frame_filter": {"frame_filter": True},
    "temporal": {"temporal": True},
    "silhouette": {"silhouette": True},
    "all": {"shared_shape": True, "frame_filter": True, "temporal": True, "silhouette": True},
}
COLUMNS = ["config", "vertex_error_mm", "root_error_deg", "keypoint_error_px", "silhouette_iou", "silhouette_iou_body",
           "jitter", "jitter_reduction", "filter_precision", "filter_recall", "frames_per_second"]


@dataclass(frozen=True)
class FitQuality:
    """One fit against the ground truth (:func:`evaluate_config`).

    Fields:
        vertex_error_mm: mean per-vertex error after aligning the root joint, mm, over the frames kept
            for training; vertex_error_mm_all_frames: the same over every frame;
        root_error_deg: mean angle between the fitted and the true root (body) orientation, degrees,
            frames kept (:func:`root_error_deg`);
        keypoint_error_px: fitted vs true (noise-free) keypoints, pixels, frames kept;
        silhouette_iou: of the fitted surface (body plus clothing offsets) vs the person's mask;
        silhouette_iou_body: of the body alone (the surface's when the fit has no offsets);
        offset_mean_mm, offset_max_mm: the clothing offsets, mm (None: the fit has none);
        jitter: mean vertex acceleration, mm / frame^2, every frame (:func:`jitter_mm`);
        filter_precision, filter_recall: rejected vs corrupted frames (None: no frame filter);
        rejected: frames the filter rejected.
    """

    vertex_error_mm: float
    vertex_error_mm_all_frames: float
    root_error_deg: float
    keypoint_error_px: float
    silhouette_iou: float
    silhouette_iou_body: float
    offset_mean_mm: float | None
    offset_max_mm: float | None
    jitter: float
    filter_precision: float | None
    filter_recall: float | None
    rejected: int

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class ConfigRow:
    """One configuration's row of fitting.json's "configs".

    Fields:
        quality: its fit against the ground truth; frames_per_second: frames over the fit and
        evaluation wall time; seconds: that wall time; jitter_reduction: share of the baseline's
        jitter removed (None: no baseline in the run, or its jitter is 0).
    """

    quality: FitQuality
    frames_per_second: float
    seconds: float
    jitter_reduction: float | None = None

    def measured(self) -> dict:
        """The quality and the timing (what is printed as each configuration finishes)."""
        return {**self.quality.to_dict(), "frames_per_second": self.frames_per_second, "seconds": self.seconds}

    def to_dict(self) -> dict:
        return {**self.measured(), "jitter_reduction": self.jitter_reduction}


@dataclass(frozen=True)
class FittingOptions:
    """What ``morf bench fitting`` fits and times.

    Fields:
        out: folder for fitting.json and fitting.md; project: an existing synthetic capture (None:
        make one in ``OUT/capture``); preset, frames: the synthetic capture preset and frame count
        when one is made (frames None: the preset's); fit_preset: the fit preset the ablation
        starts from; settings: FIELD=VALUE changes to it (as ``morf fit --set``); configs: the
        configurations of :data:`ABLATION` to fit; command_runs: also time the whole ``morf fit``
        command this many times.
    """

    out: str
    project: str | None = None
    preset: str = "default"
    frames: int | None = None
    fit_preset: str = "default"
    settings: tuple[str, ...] = ()
    configs: tuple[str, ...] = tuple(ABLATION)
    command_runs: int = 0


def _capture(opts: FittingOptions, model):
    from morf.capture.project import CaptureProject
    from morf.errors import InputError
    from morf.synth.ground_truth import has_ground_truth

    if opts.project:
        project = CaptureProject.open(opts.project)
        if not has_ground_truth(project):
            raise InputError(f"{project.root} has no ground truth; 'morf bench fitting' needs a synthetic capture")
        return project
    from morf.synth import make_synthetic_capture, synth_config

    root = Path(opts.out) / "capture"
    if CaptureProject.is_project(root) and has_ground_truth(root):
        return CaptureProject.open(root)
    cfg = synth_config(opts.preset, frames=opts.frames)
    print(f"making a synthetic capture ({cfg.frames} frames, {cfg.size}x{cfg.size}) in {root}")
    return make_synthetic_capture(root, cfg, model=model, overwrite=True)


def time_fit_command(project, runs: int, fit_preset: str = "default") -> list[float]:
    """Wall seconds of ``morf fit COPY --restart --preset FIT_PRESET`` (the installed command, a
    fresh process each time), ``runs`` times, on a copy of ``project`` without its fits (the user's
    own stay as they are)."""
    from morf.bench.common import morf_command

    command = morf_command()[0]
    seconds = []
    with tempfile.TemporaryDirectory(prefix="morf-bench-fit-") as tmp:
        copy = Path(tmp) / "capture"
        shutil.copytree(project.root, copy, ignore=shutil.ignore_patterns("fits", "runs", "avatar", "eval"))
        for _ in range(runs):
            t0 = time.perf_counter()
            r = subprocess.run([command, "fit", str(copy), "--restart", "--preset", fit_preset],
                               capture_output=True, text=True)
            seconds.append(time.perf_counter() - t0)
            if r.returncode != 0:
                raise MorfError(f"'morf fit' failed while being timed: {r.stderr.strip()[-500:]}")
    return seconds


def _vertices(model, rotvecs, transl, shape) -> np.ndarray:
    """(N, V, 3) world vertices and (N, 3) root joints, float32 numpy."""
    import torch

    from morf.fitting.evaluate import posed_chunks

    verts, roots = [], []
    for _, out in posed_chunks(model, torch.as_tensor(rotvecs, dtype=torch.float32),
                               torch.as_tensor(transl, dtype=torch.float32), torch.as_tensor(shape, dtype=torch.float32)):
        verts.append(out.vertices.numpy())
        roots.append(out.joints[:, 0].numpy())
    return np.concatenate(verts), np.concatenate(roots)


def jitter_mm(vertices: np.ndarray) -> float:
    """Mean vertex acceleration |v[t+1] - 2 v[t] + v[t-1]| over vertices and frames, mm / frame^2."""
    if len(vertices) < 3:
        return float("nan")
    acc = vertices[2:] - 2 * vertices[1:-1] + vertices[:-2]
    return float(np.linalg.norm(acc, axis=-1).mean() * 1000)


def root_error_deg(rotvecs: np.ndarray, true_rotvecs: np.ndarray) -> np.ndarray:
    """(N,) angle between the fitted and the true root orientation per frame, degrees, from
    (N, J, 3) axis-angle poses (joint 0 is the root). The vertex error cannot show it: it aligns
    the root joint's position, not its rotation, and a body turned a few degrees too little
    misplaces its texture on every side view."""
    from morf.motion.so3 import rotvec_to_matrix

    fit, true = rotvec_to_matrix(rotvecs[:, 0]), rotvec_to_matrix(true_rotvecs[:, 0])
    cos = (np.einsum("nji,nji->n", true, fit) - 1.0) / 2.0  # trace(true^T fit) = sum of elementwise products
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def bone_rotations(model, rotvecs, transl, shape, bones: tuple[str, ...]) -> np.ndarray:
    """(N, len(bones), 3, 3) world orientation of ``bones`` (their skinning rotations) of poses."""
    import torch

    from morf.body.model import BodyPose

    out = []
    with torch.no_grad():
        for s in range(0, len(rotvecs), 64):
            sh = torch.as_tensor(shape if len(shape) == 1 else shape[s:s + 64], dtype=torch.float32)
            o = model(BodyPose(torch.as_tensor(rotvecs[s:s + 64], dtype=torch.float32),
                               torch.as_tensor(transl[s:s + 64], dtype=torch.float32)), sh)
            out.append(o.bone_transforms[:, [model.bone_index(b) for b in bones], :3, :3].numpy())
    return np.concatenate(out)


def bone_error_deg(model, fits, gt, bones: tuple[str, ...]) -> np.ndarray:
    """(N, len(bones)) angle between the fitted and the true world orientation of ``bones``
    (their skinning rotations), degrees."""
    fit = bone_rotations(model, fits.rotvecs, fits.transl, fits.shape, bones)
    true = bone_rotations(model, gt.rotvecs, gt.transl, gt.shape, bones)
    cos = (np.einsum("nkji,nkji->nk", true, fit) - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


# the true head's facing against the camera, degrees from looking straight into it
VIEWS = {"front": (0.0, 45.0), "side": (45.0, 135.0), "back": (135.0, 180.1)}


def head_error_parts(model, fits, gt, camera, used: np.ndarray) -> dict:
    """Where the head's error lies, over the frames ``used`` (N,) bool: "head_error_by_view" (mean
    degrees over the frames whose true head faces the camera within 45 degrees, sideways, or away,
    with their counts) and "head_error_camera_deg": the mean size of the error rotation's
    components about the camera's axes, "pitch" (the image's horizontal axis), "yaw" (its vertical
    axis) and "roll" (the line of sight); small rotations add up by components."""
    from morf.motion.so3 import matrix_to_rotvec

    fit = bone_rotations(model, fits.rotvecs, fits.transl, fits.shape, ("head",))[:, 0].astype(np.float64)
    true = bone_rotations(model, gt.rotvecs, gt.transl, gt.shape, ("head",))[:, 0].astype(np.float64)
    C = np.asarray(camera.R, np.float64)
    err = np.degrees(np.arccos(np.clip((np.einsum("nji,nji->n", true, fit) - 1.0) / 2.0, -1.0, 1.0)))
    parts = np.degrees(matrix_to_rotvec(np.einsum("nij,nkj->nik", fit, true))) @ C.T  # camera axes
    face = np.einsum("ij,njk,k->ni", C, true, np.array([0.0, -1.0, 0.0]))  # the body model faces -y
    facing = np.abs(np.degrees(np.arctan2(face[:, 0], -face[:, 2])))
    by_view = {}
    for name, (lo, hi) in VIEWS.items():
        sel = used & (facing >= lo) & (facing < hi)
        by_view[name] = {"frames": int(sel.sum()), "head_error_deg": float(err[sel].mean()) if sel.any() else None}
    return {"head_error_by_view": by_view,
            "head_error_camera_deg": {k: float(np.abs(parts[used, i]).mean()) for i, k in
                                      enumerate(("pitch", "yaw", "roll"))}}


def evaluate_config(model, fits, rejected: dict[int, str], gt, gt_verts, gt_roots) -> FitQuality:
    """Metrics of one fit against the ground truth (a :class:`morf.synth.ground_truth.GroundTruth`
    with keypoints_true and corrupted)."""
    verts, roots = _vertices(model, fits.rotvecs, fits.transl, fits.shape)
    N = len(verts)
    used = np.ones(N, bool)
    used[list(rejected)] = False
    err = np.linalg.norm((verts - roots[:, None]) - (gt_verts - gt_roots[:, None]), axis=-1).mean(1) * 1000
    true_kp = gt.keypoints_true
    ok = true_kp[..., 2] > 0
    kp_err = np.linalg.norm(fits.projected_keypoints - true_kp[..., :2], axis=-1)
    kp_err = np.where(ok, kp_err, np.nan)
    corrupted = gt.corrupted.astype(bool)
    flagged = ~used
    precision = recall = None
    if fits.config.get("frame_filter"):
        precision = float((flagged & corrupted).sum() / max(1, flagged.sum())) if flagged.any() else 1.0
        recall = float((flagged & corrupted).sum() / max(1, corrupted.sum())) if corrupted.any() else 1.0
    return FitQuality(
        vertex_error_mm=float(err[used].mean()),
        vertex_error_mm_all_frames=float(err.mean()),
        root_error_deg=float(root_error_deg(fits.rotvecs, gt.rotvecs)[used].mean()),
        keypoint_error_px=float(np.nanmean(kp_err[used])),
        silhouette_iou=float(np.nanmean(fits.silhouette_iou[used])),
        silhouette_iou_body=float(np.nanmean((fits.silhouette_iou if fits.silhouette_iou_body is None
                                              else fits.silhouette_iou_body)[used])),
        offset_mean_mm=None if fits.offsets is None else float(fits.offsets.mean() * 1000),
        offset_max_mm=None if fits.offsets is None else float(fits.offsets.max() * 1000),
        jitter=jitter_mm(verts),
        filter_precision=precision,
        filter_recall=recall,
        rejected=len(rejected),
    )


def head_hands_errors(model, fits, rejected: dict[int, str], gt, camera=None) -> dict:
    """{"head_error_deg", "wrist_error_deg"}: mean angle between the fitted and the true world
    orientation of the head bone and of the two wrist bones over the frames kept, degrees (the
    root's error included, as the image shows it), "landmark_residual_px" (face, left hand,
    right hand; medians) when the fit refined them to landmarks, and with the capture's
    ``camera`` the head's error by view and about the camera's axes (:func:`head_error_parts`)."""
    used = np.ones(fits.num_frames, bool)
    used[list(rejected)] = False
    err = bone_error_deg(model, fits, gt, ("head", "wrist.L", "wrist.R"))[used]
    out = {"head_error_deg": float(err[:, 0].mean()), "wrist_error_deg": float(err[:, 1:].mean()),
           "landmark_residual_px": None}
    if camera is not None:
        out.update(head_error_parts(model, fits, gt, camera, used))
    if fits.landmark_residual_px is not None:
        out["landmark_residual_px"] = [float(v) for v in np.nanmedian(fits.landmark_residual_px[used], 0)]
    return out


def _time_command(project, opts: FittingOptions) -> dict | None:
    """``morf fit`` as a user runs it, timed before the ablation (None without ``command_runs``)."""
    if opts.command_runs <= 0:
        return None
    print(f"timing 'morf fit' as a whole command, {opts.command_runs} runs")
    seconds = time_fit_command(project, opts.command_runs, opts.fit_preset)
    fps = [project.num_frames / t for t in seconds]
    return {"command": f"morf fit CAPTURE --restart --preset {opts.fit_preset} (fresh processes)",
            "seconds": seconds, "frames_per_second": fps, "median_frames_per_second": float(np.median(fps))}


def _fit_configs(model, inputs, base, keys, gt, gt_verts, gt_roots) -> tuple[dict[str, ConfigRow], dict[str, dict]]:
    """Fit each configuration of ``keys`` from scratch and score it against the ground truth
    (``gt_verts``, ``gt_roots``: its posed vertices and root joints, :func:`_vertices`):
    ({key: ConfigRow with its jitter reduction}, {key: head and hands errors})."""
    import torch

    from morf.fitting import finalize, fit_sequence

    results: dict[str, ConfigRow] = {}
    head_hands: dict[str, dict] = {}
    for key in keys:
        cfg = base.replace(**ABLATION[key])
        print(f"fitting: {key}")
        t0 = time.perf_counter()
        state = fit_sequence(model, inputs, cfg, device=torch.device("cpu"))
        fits, rejected = finalize(model, inputs, cfg, state)
        seconds = time.perf_counter() - t0
        row = ConfigRow(evaluate_config(model, fits, rejected, gt, gt_verts, gt_roots), inputs.num_frames / seconds,
                        seconds)
        results[key] = row
        head_hands[key] = head_hands_errors(model, fits, rejected, gt, inputs.camera)
        print("  " + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                               for k, v in {**row.measured(), **head_hands[key]}.items()))
    base_jitter = results["baseline"].quality.jitter if "baseline" in results else None
    results = {k: replace(row, jitter_reduction=None if not base_jitter else 1.0 - row.quality.jitter / base_jitter)
               for k, row in results.items()}
    return results, head_hands


HEAD_COLUMNS = ["config", "head_error_deg", "front", "side", "back", "pitch", "yaw", "roll", "wrist_error_deg"]


def _head_row(key: str, d: dict) -> dict:
    """One row of the head table: the head's error over all kept frames, by view (front / side /
    back, with their frame counts) and about the camera's axes, and the wrists'."""
    row = {"config": key, "head_error_deg": d["head_error_deg"], "wrist_error_deg": d["wrist_error_deg"]}
    for view, v in d.get("head_error_by_view", {}).items():
        row[view] = "n/a" if v["head_error_deg"] is None else f"{v['head_error_deg']:.3g} ({v['frames']})"
    row.update(d.get("head_error_camera_deg", {}))
    return row


def _markdown(summary: dict, project, results: dict[str, ConfigRow], head_hands: dict[str, dict]) -> str:
    rows = [{"config": k, **row.to_dict()} for k, row in results.items()]
    md = (f"# Mesh fitting ablation\n\nCapture: {project.num_frames} frames, "
          f"{project.image_size[0]}x{project.image_size[1]}, {summary['capture']['corrupted_frames']} corrupted; "
          f"true motion jitter {summary['capture']['true_jitter']:.2f} mm/frame^2.\n\n"
          + markdown_table(rows, COLUMNS)
          + "\n\nHead and wrists (world orientation against the truth, degrees, frames kept; the head by "
          "view, frames in brackets, and about the camera's axes; "
          + ("landmarks: " + ("yes" if summary["landmarks"] else "none in the capture")) + "):\n\n"
          + markdown_table([_head_row(k, d) for k, d in head_hands.items()], HEAD_COLUMNS))
    command = summary.get("command")
    if command is not None:
        md += ("\n\n'morf fit' as a whole command (fresh process, start-up, evaluation and overlays counted): "
               + " / ".join(f"{t:.1f} s" for t in command["seconds"])
               + f", median {command['median_frames_per_second']:.2f} frames/s\n")
    return md


def run_fitting(opts: FittingOptions) -> dict:
    """Fit every configuration of ``opts.configs`` from scratch against the ground truth; writes
    fitting.json and fitting.md; returns fitting.json's content."""
    from morf.body import load_body_model
    from morf.errors import InputError
    from morf.fitting import load_fit_inputs, preset
    from morf.synth.ground_truth import load_ground_truth

    unknown = [k for k in opts.configs if k not in ABLATION]
    if unknown:
        raise InputError(f"unknown fitting configs: {', '.join(unknown)}; choose from {', '.join(ABLATION)}")
    base = preset(opts.fit_preset).with_settings(list(opts.settings)).replace(
        shared_shape=False, frame_filter=False, temporal=False, silhouette=False, overlays=False)
    model = load_body_model("anny")
    project = _capture(opts, model)
    command = _time_command(project, opts)
    gt = load_ground_truth(project, require=("keypoints_true", "corrupted"))
    inputs = load_fit_inputs(project, project.camera(), base.silhouette_resolution, base.iou_resolution)
    gt_verts, gt_roots = _vertices(model, gt.rotvecs, gt.transl, gt.shape)
    results, head_hands = _fit_configs(model, inputs, base, list(opts.configs), gt, gt_verts, gt_roots)
    summary = {
        "capture": {"project": str(project.root), "frames": project.num_frames, "size": list(project.image_size),
                    "corrupted_frames": int(gt.corrupted.sum()),
                    "true_jitter": jitter_mm(gt_verts),
                    "keypoints": project.manifest.get("source", {}).get("keypoints")},
        "fit_preset": opts.fit_preset,
        "fit_settings": list(opts.settings),
        "machine": machine_info(),
        "configs": {k: row.to_dict() for k, row in results.items()},
        "head_hands": head_hands,
        "landmarks": inputs.landmarks is not None,
    }
    if command is not None:
        summary["command"] = command
    md = _markdown(summary, project, results, head_hands)
    path = write_results(opts.out, "fitting", summary, md)
    print(md)
    print(f"wrote {path}")
    return summary
