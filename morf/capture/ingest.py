"""``ingest``: a video or images -> a capture project (frames, 2D keypoints, person masks).

Images given without a frame rate (``--frames DIR`` without ``--fps``) are recorded as unordered
views (a photo set: the manifest's ``unordered_views``), which fitting treats as views from
several sides with no neighbours in time; with ``--fps`` they are a clip.

Keypoints come from MediaPipe, or from OpenPose JSON files (``keypoints``); masks from
MediaPipe's segmentation, or from mask images (``masks``). When a frame shows several people
the largest is followed (:mod:`morf.capture.people`); the choice is printed and recorded in
the manifest under ``ingest.people``.

The project is built in a hidden folder beside it and swapped in at the end
(:mod:`morf.capture.staging`): re-running replaces the outputs whole, and a failure or a stop
leaves the previous project untouched.
"""

from __future__ import annotations

from contextlib import closing
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from morf.camera import PinholeCamera
from morf.capture.frame_times import FrameTiming, frame_timing
from morf.capture.frame_writer import FrameWriter
from morf.capture.labelling import FrameLabel, FrameLabeller
from morf.capture.matching import FileMatch, list_files, match_files
from morf.capture.openpose import HandsFace
from morf.capture.people import TrackerConfig
from morf.capture.project import CaptureProject, Keypoints2D
from morf.capture.staging import check_replaceable, staged_folder
from morf.capture.video import IMAGE_EXTS, MAX_SIDE, MIN_SIDE, FrameSource, exif_focal_px, open_images, open_video
from morf.errors import InputError, MorfError, ProjectError
from morf.io import save_npz
from morf.pipeline.control import Progress, StageControl
from morf.progress import progress

HANDS_FACE_FILE = "keypoints_hands_face.npz"
JPEG_AFTER = 300  # "auto" frame format: PNG up to this many frames, JPEG (quality 95) beyond


@dataclass(frozen=True)
class IngestConfig:
    """What to ingest and how. Exactly one of ``video`` and ``frames`` is set."""

    video: Path | None = None  # a video file
    frames: Path | None = None  # a folder of images, or one image file
    keypoints: Path | None = None  # OpenPose JSON folder (or file) instead of MediaPipe keypoints
    masks: Path | None = None  # mask images folder (or file) instead of MediaPipe masks
    max_frames: int | None = None  # keep at most this many frames (after subsampling)
    every: int = 1  # keep every k-th source frame
    resize: int | None = None  # scale frames so the longest side has this many pixels
    fps: float | None = None  # source frame rate, overriding the video's metadata
    focal: float | None = None  # focal length in source pixels (else EXIF, else a default)
    frame_format: str = "auto"  # "png" | "jpg" | "auto"
    force: bool = False  # replace a project that already has fits / runs / an avatar
    mirror_average: bool = True  # MediaPipe's keypoints averaged with its pass on the mirrored frame
    # detect face and hand landmarks (MediaPipe face mesh and hands on crops) for the fit's head and
    # hands, unless the OpenPose files brought their own face and hand points
    face_hands: bool = True
    tracker: TrackerConfig = field(default_factory=TrackerConfig)  # person choice and following

    def validate(self) -> None:
        if (self.video is None) == (self.frames is None):
            raise InputError("give exactly one input: --video FILE or --frames DIR_OR_IMAGE")
        if self.every < 1:
            raise InputError(f"--every must be at least 1, got {self.every}")
        if self.max_frames is not None and self.max_frames < 1:
            raise InputError(f"--max-frames must be at least 1, got {self.max_frames}")
        if self.resize is not None and not MIN_SIDE <= self.resize <= MAX_SIDE:
            raise InputError(f"--resize must be between {MIN_SIDE} and {MAX_SIDE} px, got {self.resize}")
        for name in ("fps", "focal"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"--{name} must be a positive number, got {v}")
        if self.frame_format not in ("auto", "png", "jpg"):
            raise InputError(f"frame format must be png, jpg or auto, got {self.frame_format!r}")


@dataclass(frozen=True)
class IngestResult:
    """What ingest made: the project, its frame count and size, and what it noticed."""

    root: Path
    num_frames: int
    width: int
    height: int
    detected: int  # frames with the person found
    people_seen: int  # most people seen at once
    rechosen: tuple[int, ...]  # frames where the followed person was chosen afresh
    replaced: bool  # an existing project was replaced
    warnings: tuple[str, ...]
    unordered_views: bool = False  # images without a frame rate: recorded as a photo set


def output_size(width: int, height: int, resize: int | None) -> tuple[float, int, int]:
    """(scale, out_width, out_height) for ``--resize`` (longest side in pixels)."""
    if resize is None:
        return 1.0, width, height
    s = resize / max(width, height)
    w, h = max(1, round(width * s)), max(1, round(height * s))
    if min(w, h) < MIN_SIDE:
        raise InputError(f"--resize {resize} makes {width}x{height} frames {w}x{h}, under {MIN_SIDE} px")
    return s, w, h


def _open_source(config: IngestConfig) -> FrameSource:
    if config.video is not None:
        return open_video(config.video, config.resize)
    return open_images(config.frames, config.resize)


def _match(path: Path | None, exts, what: str, source: FrameSource, wanted: list[int]) -> FileMatch | None:
    if path is None:
        return None
    files = list_files(path, exts, what)
    exact = source.frame_count if source.kind != "video" else None
    names = source.names if source.kind != "video" else None
    return match_files(files, wanted, names, exact, what)


def _camera(config: IngestConfig, source: FrameSource, scale: float, w: int, h: int) -> tuple[PinholeCamera, str]:
    focal, where = config.focal, "user"
    if focal is None and source.kind != "video":
        focal, where = exif_focal_px(source.files[0], source.width, source.height), "exif"
    if focal is None:
        return PinholeCamera.default_for_image(w, h), "default"
    f = focal * scale
    return PinholeCamera(f, f, w / 2, h / 2, w, h), where


def ingest(project: str | Path, config: IngestConfig, control: StageControl | None = None,
           log: Callable[[str], None] = print) -> IngestResult:
    """Ingest ``config``'s input into the project folder ``project`` (created or replaced).

    Raises :class:`~morf.errors.MorfError` (one line) on bad input, including an input in which
    no frame shows a person; the project is then unchanged (or, when there was none, not made).
    ``control`` receives a :class:`Progress` per frame and can pause or stop
    (:class:`~morf.pipeline.control.StopRequested` also leaves the project unchanged).
    ``log`` receives the sentences worth showing a user (people seen, the choice made).
    """
    config.validate()
    control = control or StageControl()
    root = Path(project)
    replaced = check_replaceable(root, config.force)
    source = _open_source(config)
    scale, out_w, out_h = output_size(source.width, source.height, config.resize)
    wanted = source.kept_indices(config.every, config.max_frames) or []
    kp_match = _match(config.keypoints, (".json",), "OpenPose", source, wanted)
    mask_match = _match(config.masks, IMAGE_EXTS, "mask", source, wanted)
    camera, focal_source = _camera(config, source, scale, out_w, out_h)
    total = len(wanted) or None
    fmt = config.frame_format if config.frame_format != "auto" else ("jpg" if (total or 0) > JPEG_AFTER else "png")
    ext = "." + fmt

    labeller = FrameLabeller(kp_match, mask_match, (source.width, source.height), scale, config.tracker,
                             mirror_average=config.mirror_average)
    rows: list[tuple[int, FrameLabel]] = []
    times: list[float | None] = []
    if source.rotation:
        turn = "clockwise" if source.rotation < 0 else "counter-clockwise"
        log(f"turning frames {abs(source.rotation)} degrees {turn}, as the video's rotation metadata says")
    try:
        with staged_folder(root) as staging:
            with FrameWriter(staging, ext, "ingest", "ingesting", total, control) as out, closing(labeller):
                for n, frame in out.numbered(source.frames(config.every, config.max_frames)):
                    rgb = frame.rgb
                    if scale != 1.0:
                        interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
                        rgb = cv2.resize(rgb, (out_w, out_h), interpolation=interp)
                    label = labeller.label(frame.index, rgb)
                    out.write(n, rgb, label.mask)
                    rows.append((frame.index, replace(label, mask=None)))  # masks are on disk: memory stays flat
                    times.append(frame.time)
            if not rows:
                raise InputError(f"no frames could be read from {source.path}")
            source_total = source.frame_count if source.kind != "video" else (
                None if config.max_frames and len(rows) == config.max_frames else source.decoded)
            labeller.check_complete(len(rows), source_total, source.ended_early)
            if not any(label.found for _, label in rows):
                raise InputError(_nobody_found(len(rows), source, config))
            people = _people_record(labeller, rows, config)
            timing = frame_timing(times, config.fps or source.fps, config.fps is not None) \
                if source.kind == "video" else FrameTiming(None, "fps" if config.fps else "none")
            _write_outputs(staging, rows, labeller, scale, source, config, camera, focal_source, ext, people, timing)
            for line in _people_sentences(people) + ([timing.sentence()] if timing.sentence() else []):
                log(line)
    except OSError as e:
        raise ProjectError(f"writing the project {root} failed: {e}") from None
    if config.face_hands and not labeller.has_hands_face:
        _detect_face_hands(root, control, log)
    detected = sum(1 for _, lab in rows if lab.found)
    return IngestResult(root, len(rows), out_w, out_h, detected, labeller.people_seen,
                        tuple(labeller.rechosen_frames), replaced, tuple(source.warnings + labeller.warnings),
                        unordered_views=source.kind != "video" and (config.fps or source.fps) is None)


def _detect_face_hands(root: Path, control: StageControl, log: Callable[[str], None]) -> None:
    """Face and hand landmarks of the ingested project, stored beside its keypoints
    (``morf.capture.landmarks_detect``). Without MediaPipe the project stays without them (the fit
    then leaves the head and the hands as the body keypoints put them) and the user is told."""
    from morf.capture.landmarks_detect import detect_project_landmarks

    project = CaptureProject.open(root)
    n = project.num_frames
    bar = progress(total=n, desc="face and hands", unit="frame")

    def step(i: int) -> None:
        bar.update(1)
        control.check()
        control.report(Progress("ingest", i + 1, n, f"face and hand landmarks, frame {i + 1}", frame=i))

    try:
        lm = detect_project_landmarks(project, progress=step)
    except MorfError as e:
        log(f"face and hand landmarks not detected ({e}); the fit will pose the head and hands from the body "
            "keypoints alone")
        return
    finally:
        bar.close()
    found = int((lm.face[:, :, 2].max(1) > 0).sum())
    hands = int(((lm.hand_left[:, :, 2].max(1) > 0) | (lm.hand_right[:, :, 2].max(1) > 0)).sum())
    log(f"face landmarks found in {found} of {n} frames, a hand in {hands}")


def _nobody_found(frames: int, source: FrameSource, config: IngestConfig) -> str:
    """The error for an input in which no frame shows the person: nothing could be fitted or trained
    on such a project, so none is made."""
    where = f"any of the {frames} frames of {source.path}"
    if config.keypoints is not None:
        return (f"no person was found in {where}: the OpenPose files in {config.keypoints} hold nobody; give the "
                f"keypoints OpenPose found on these frames")
    return (f"no person was found in {where}; film one person, whole body in view and well lit (or give their "
            f"keypoints with --keypoints DIR)")


def _people_record(labeller: FrameLabeller, rows, config: IngestConfig) -> dict:
    if config.masks is not None and config.keypoints is None:
        rule = "the person in the imported masks"
    else:
        rule = "largest person in the first frame with anybody, then followed by box overlap"
    return {"seen": labeller.people_seen, "followed": rule, "rechosen_at_frames": list(labeller.rechosen_frames)}


def _people_sentences(people: dict) -> list[str]:
    out = []
    if people["seen"] > 1:
        follow = "following the largest" if "largest" in people["followed"] else "following the masked person"
        out.append(f"{people['seen']} people seen; {follow}")
    for f in people["rechosen_at_frames"]:
        out.append(f"lost the followed person; chose the largest person again at frame {f}")
    return out


def _write_outputs(staging: Path, rows, labeller: FrameLabeller, scale: float, source: FrameSource,
                   config: IngestConfig, camera: PinholeCamera, focal_source: str, ext: str, people: dict,
                   timing: FrameTiming) -> None:
    labels = [lab for _, lab in rows]
    kp = Keypoints2D(np.stack([lab.points for lab in labels]).astype(np.float32),
                     np.array([lab.found for lab in labels], bool),
                     np.array([lab.source if lab.found else "none" for lab in labels], str))
    extras = {}
    if labeller.has_hands_face:
        hf = HandsFace.stack([lab.person for lab in labels], scale)
        save_npz(staging / HANDS_FACE_FILE, **asdict(hf))
        extras["hands_face"] = HANDS_FACE_FILE
    fps = config.fps or source.fps
    record = {
        "source_size": [source.width, source.height], "scale": scale, "every": config.every,
        "max_frames": config.max_frames, "resize": config.resize,
        "keypoints_from": "openpose" if config.keypoints else "mediapipe",
        "keypoints_mirror_average": labeller.mirror_average,
        "masks_from": "import" if config.masks else "mediapipe",
        "openpose_layouts": sorted(labeller.layouts), "focal_source": focal_source,
        "people": people, "warnings": source.warnings + labeller.warnings,
        "source_frames": [i for i, _ in rows], "timing": timing.record(), **extras,
    }
    if source.kind == "video":
        record.update(decoder=source.decoder, rotation=source.rotation)
    top = {"frame_ext": ext, "ingest": record}
    if fps is None and source.kind != "video":
        top["unordered_views"] = True  # photos of a person, not a clip: no frame is another's neighbour
    if timing.times is not None:
        top["frame_times"] = [round(float(t), 6) for t in timing.times]  # microseconds are plenty
    project = CaptureProject.create(
        staging, num_frames=len(rows), width=camera.width, height=camera.height,
        fps=None if fps is None else fps / config.every,
        source={"kind": source.kind, "path": str(source.path.resolve()), "fps": fps,
                "frames_decoded": source.decoded},
        camera=camera, extra=top)
    project.save_keypoints(kp)
    project.save_manifest()  # last, so a manifest always describes complete outputs
