"""``make_synthetic_capture``: a capture project of a rendered person with known ground truth.

The project has exactly the layout of a real capture (frames/, masks/, keypoints.npz,
morf_project.json with the camera), so every later stage runs on it unchanged, plus::

    ground_truth/
      synth_config.json      the resolved SynthConfig (re-running it rebuilds the same files)
      camera.json            the camera (PinholeCamera.to_dict)
      gt.npz                 per capture frame: the true poses, shape, keypoints, corrupted frames,
                             cloth sliding field, garment offsets and regions (format and reader:
                             morf.synth.ground_truth)
      masks/000000.png       clean rendered masks of the dressed person (equal to the project's
                             masks as written; kept here in case those are replaced)
      body_masks/000000.png  masks of the body alone, without the loose garments
      detector_masks/        the detector's person masks, for frames where it found the person
      texture.png            the clothing atlas (row 0 = v 1), without sliding
      holdout/frames/, holdout/masks/
                             a sequence in novel poses (arm raises, hip sway, steps), with the
                             same garments but no cloth sliding
      holdout.npz            its poses, keypoints and camera (morf.synth.ground_truth)

The manifest is written last, so an interrupted run never looks like a finished project.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.camera import PinholeCamera
from morf.capture.project import FITS_DIR, MANIFEST, CaptureProject, Keypoints2D
from morf.errors import InputError
from morf.io import atomic_write_json, write_image
from morf.pipeline.control import Progress, StageControl
from morf.progress import progress
from morf.raster import render_textured, rasterize_uv, upload_texture
from morf.synth.config import SynthConfig
from morf.synth.ground_truth import GroundTruth, HoldoutSequence, save_ground_truth, save_holdout, write_holdout_images
from morf.synth.keypoints import close_detector, detect, make_detector, noisy, project_keypoints
from morf.synth.motion import MotionSequence, capture_motion, holdout_motion, view_frames
from morf.synth.nuisance import SlideField, corrupt_keypoints, make_slide_field
from morf.synth.scene import SynthScene, build_scene, posed_frames, rng_streams

_OUTPUTS = ("frames", "masks", "ground_truth", FITS_DIR, "runs", "avatar", "keypoints.npz", "review.json", MANIFEST)


def _prepare_folder(root: Path, overwrite: bool) -> None:
    if root.exists() and not root.is_dir():
        raise InputError(f"not a folder: {root}")
    if root.is_dir() and any(root.iterdir()):
        if not overwrite:
            raise InputError(f"{root} is not empty; choose a new folder or pass --force to rebuild a synthetic project")
        if not (CaptureProject.is_project(root) and CaptureProject(root, {}).is_synthetic):
            raise InputError(f"{root} is not empty and not a synthetic MoRF project; refusing to overwrite it")
        for name in _OUTPUTS:  # everything here was derived from the old capture
            p = root / name
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                p.unlink()
    root.mkdir(parents=True, exist_ok=True)


def _frame_uvs(scene: SynthScene, field: SlideField, frame: int) -> np.ndarray:
    uv = scene.mesh.uvs.astype(np.float64)
    return (uv + scene.slide_weight[:, None] * field.displacement(uv, frame)).astype(np.float32)


@dataclass(frozen=True)
class CapturePlan:
    """What the capture will show, drawn from the config's random streams before anything is
    rendered.

    Fields:
        scene: the dressed body, its clothing and the camera.
        motion: the poses of the N kept frames.
        keep: (N,) int indices of the kept frames among the config's ``frames``.
        field: the cloth sliding over all ``frames`` frames (the kept ones: ``keep``).
        corrupted: (N,) bool kept frames whose keypoints get a wrong pose.
    """

    scene: SynthScene
    motion: MotionSequence
    keep: np.ndarray
    field: SlideField
    corrupted: np.ndarray


def plan_capture(config: SynthConfig, streams, model=None) -> CapturePlan:
    """Dress the body, draw the motion and the frames kept of it, the cloth sliding and the frames
    whose keypoints are corrupted (each from its own random stream of ``streams``)."""
    scene = build_scene(config, streams, model)
    full = capture_motion(scene.model.bone_names, config.frames, streams["motion"], config.turn_fraction, config.sway,
                          config.arms_out_deg, config.turn_degrees)
    keep = kept_frames(full, config)
    field = make_slide_field(config.frames, config.slide, streams["slide"])
    n_bad = int(round(config.corrupt * config.frames))
    corrupted = np.zeros(config.frames, bool)
    corrupted[streams["corrupt"].choice(config.frames, size=n_bad, replace=False)] = True
    return CapturePlan(scene, full.take(keep), keep, field, corrupted[keep])


@dataclass(frozen=True)
class CaptureKeypoints:
    """The keypoints of the N rendered capture frames.

    Fields:
        points: (N, 23, 3) float32 what the project's keypoints.npz holds: detected, or the
            truth with noise; a wrong pose's in the corrupted frames.
        source: (N,) str "mediapipe" or "ground_truth", where ``points`` came from.
        true_points: (N, 23, 3) float32 the body model's keypoints projected, confidence 1.
        keypoints3d: (N, 23, 3) float32 the same in world coordinates (metres).
        corruption: (N,) str the kind of corruption of each frame, "" for none.
    """

    points: np.ndarray
    source: np.ndarray
    true_points: np.ndarray
    keypoints3d: np.ndarray
    corruption: np.ndarray


def make_synthetic_capture(root, config: SynthConfig, *, model=None, control: StageControl | None = None,
                           overwrite: bool = False) -> CaptureProject:
    """Render a synthetic capture project into ``root``.

    Args:
        root: project folder (created; must be empty unless ``overwrite`` and it is a synthetic project).
        config: a validated :class:`SynthConfig` (see ``synth_config``).
        model: an already loaded body model (Anny) to reuse; loaded when None.
        control: progress reports and pause/stop between frames.
    Returns:
        the opened :class:`CaptureProject`.
    """
    config.validate()
    control = control or StageControl()
    root = Path(root)
    _prepare_folder(root, overwrite)
    streams = rng_streams(config.seed)
    M = config.holdout_frames
    control.report(Progress("synth", 0, config.frames + M, "dressing the body"))
    plan = plan_capture(config, streams, model)
    N = len(plan.keep)
    writer = CaptureProject(root, {"num_frames": N, "frame_ext": ".png", "width": config.size, "height": config.size})
    detector = make_detector(config.detector)
    texture = upload_texture(plan.scene.clothing.image)
    bar = progress(total=N + M, desc="synth", unit="frame")
    try:
        keypoints = _render_capture(plan, config, streams, texture, detector, writer, control, bar)
        _render_holdout(plan.scene, config, streams, texture, writer, control, bar, N)
    finally:
        bar.close()
        texture.release()
        close_detector(detector)
    used = _write_truth(writer, plan, keypoints, config, "mediapipe" if detector is not None else "none")
    return CaptureProject.create(
        root, num_frames=N, width=config.size, height=config.size, fps=None if config.photo_set else config.fps,
        camera=plan.scene.camera, source={"kind": "synthetic", "preset": config.preset, "seed": config.seed,
                                          "keypoints": used["detector"]},
        extra={"frame_ext": ".png", **_timing(plan.keep, config)})


def _render_capture(plan: CapturePlan, config: SynthConfig, streams, texture, detector, writer: CaptureProject,
                    control: StageControl, bar) -> CaptureKeypoints:
    """Render the kept frames into the project (frames, masks) and its ground truth (clean and
    body-only masks, the detector's masks), and give their keypoints."""
    scene, cam, keep, N = plan.scene, plan.scene.camera, plan.keep, len(plan.keep)
    gt_dir = writer.ground_truth_dir
    points = np.zeros((N, 23, 3), np.float32)
    true_points = np.zeros((N, 23, 3), np.float32)
    kp3d = np.zeros((N, 23, 3), np.float32)
    source = np.full(N, "ground_truth", dtype="<U16")
    corruption = np.full(N, "", dtype="<U16")
    for i, posed in enumerate(posed_frames(scene, plan.motion.rotvecs, plan.motion.transl)):
        control.check()
        rgb, mask = render_textured(posed.dressed, scene.mesh, cam, texture, background=config.background,
                                    msaa=config.msaa, shading=config.shading,
                                    uvs=_frame_uvs(scene, plan.field, int(keep[i])))
        body_mask = rasterize_uv(posed.body, scene.mesh, cam).mask
        kp3d[i] = posed.keypoints3d
        true_points[i] = project_keypoints(posed.keypoints3d[None], cam)[0]
        found, det_mask = detect(detector, rgb) if detector is not None else (None, None)
        if found is not None:
            points[i], source[i] = found, "mediapipe"
            if det_mask is not None:
                det_png = (np.clip(det_mask, 0, 1) * 255).astype(np.uint8)
                write_image(gt_dir / "detector_masks" / f"{i:06d}.png", det_png)
        else:
            points[i] = noisy(true_points[i], config.kp_noise, streams["noise"])
        if plan.corrupted[i]:
            points[i], corruption[i] = corrupt_keypoints(points[i], streams["corrupt"])
        writer.save_frame(i, rgb)
        writer.save_mask(i, mask)
        write_image(gt_dir / "masks" / f"{i:06d}.png", mask.astype(np.uint8) * 255)
        write_image(gt_dir / "body_masks" / f"{i:06d}.png", body_mask.astype(np.uint8) * 255)
        bar.update(1)
        control.report(Progress("synth", i + 1, N + config.holdout_frames, f"capture frame {i + 1}/{N}", frame=i))
    return CaptureKeypoints(points, source, true_points, kp3d, corruption)


def _write_truth(writer: CaptureProject, plan: CapturePlan, keypoints: CaptureKeypoints, config: SynthConfig,
                 detector: str) -> dict:
    """The project's keypoints and the ground truth's files besides the rendered masks (texture,
    camera, gt.npz, the resolved config). Returns what was used (``detector``: "mediapipe" or
    "none"), as synth_config.json records it."""
    scene, motion, field, keep = plan.scene, plan.motion, plan.field, plan.keep
    gt_dir = writer.ground_truth_dir
    writer.save_keypoints(Keypoints2D(points=keypoints.points, detected=np.ones(len(keep), bool),
                                      source=keypoints.source))
    write_image(gt_dir / "texture.png", scene.clothing.image)
    atomic_write_json(gt_dir / "camera.json", scene.camera.to_dict())
    save_ground_truth(writer, GroundTruth(
        rotvecs=motion.rotvecs, transl=motion.transl, shape=scene.shape.numpy(), yaw=motion.yaw,
        phase=motion.phase.astype(str), keypoints3d=keypoints.keypoints3d, keypoints_true=keypoints.true_points,
        corrupted=plan.corrupted, corruption=keypoints.corruption, slide_freqs=field.freqs, slide_phases=field.phases,
        slide_coeffs=field.coeffs[keep].astype(np.float32), slide_weight=scene.slide_weight,
        slide_grid=np.stack([field.grid(int(i)) for i in keep]).astype(np.float32),
        loose_offset=scene.loose_offset, vertex_regions=scene.vertex_regions))
    used = {"detector": detector, "frames_with_detector_keypoints": int((keypoints.source == "mediapipe").sum())}
    atomic_write_json(gt_dir / "synth_config.json", {"config": config.to_dict(), "resolved": used})
    return used


def kept_frames(motion: MotionSequence, config: SynthConfig) -> np.ndarray:
    """Indices of the frames of ``motion`` the capture keeps: all, or ``config.views`` of the turn."""
    if config.views <= 0:
        return np.arange(len(motion.yaw))
    return view_frames(motion.yaw, motion.phase, config.views, config.turn_degrees)


def _timing(keep: np.ndarray, config: SynthConfig) -> dict:
    """The manifest's timing of the kept frames: none for every frame (index / fps), their times for
    views of a clip, and unordered views for a photo set (no times at all)."""
    if config.photo_set:
        return {"unordered_views": True}
    if config.views > 0:
        return {"frame_times": [round(float(i) / config.fps, 6) for i in keep]}
    return {}


def _render_holdout(scene: SynthScene, config: SynthConfig, streams, texture, writer: CaptureProject,
                    control: StageControl, bar, N: int) -> None:
    """Novel poses with the same garments and no sliding, for judging generalisation (``N``: the
    capture frames rendered before them, for the progress count)."""
    M = config.holdout_frames
    motion = holdout_motion(scene.model.bone_names, M, streams["holdout"])
    cam: PinholeCamera = scene.camera
    kp = np.zeros((M, 23, 3), np.float32)
    for j, posed in enumerate(posed_frames(scene, motion.rotvecs, motion.transl)):
        control.check()
        rgb, mask = render_textured(posed.dressed, scene.mesh, cam, texture, background=config.background,
                                    msaa=config.msaa, shading=config.shading)
        write_holdout_images(writer, j, rgb, mask)
        kp[j] = project_keypoints(posed.keypoints3d[None], cam)[0]
        bar.update(1)
        control.report(Progress("synth", N + j + 1, N + M, f"hold-out frame {j + 1}/{M}"))
    save_holdout(writer, HoldoutSequence(rotvecs=motion.rotvecs, transl=motion.transl, shape=scene.shape.numpy(),
                                         yaw=motion.yaw, phase=motion.phase.astype(str), keypoints=kp, camera=cam))
