"""Writing a dataset sequence as a capture project, the way ``morf ingest`` writes a video.

The project is built in a hidden folder beside the target and swapped in at the end
(:mod:`morf.capture.staging`), so a failure or a stop leaves any previous project untouched.
Masks come from the dataset; 2D keypoints come from MediaPipe run on a crop around each
mask (the same rule ``morf ingest --masks`` follows), or are marked undetected when the
detector is switched off. Reference material that our pipeline does not consume (SMPL
parameters, the other cameras' frames) goes into ``PROJECT/dataset/`` through a callback.
"""

from __future__ import annotations

from contextlib import closing
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from morf.camera import PinholeCamera
from morf.capture.detect_mediapipe import MediaPipeDetector
from morf.capture.frame_writer import FrameWriter
from morf.capture.keypoint_layout import NUM_KEYPOINTS
from morf.capture.labelling import mask_box
from morf.capture.people import TrackerConfig, detect_in_region, expand_box
from morf.capture.project import CaptureProject, Keypoints2D
from morf.capture.staging import check_replaceable, staged_folder
from morf.datasets.frames import DatasetFrame
from morf.errors import InputError, ProjectError
from morf.pipeline.control import StageControl

DATASET_DIR = "dataset"  # PROJECT/dataset/: what the dataset provides beyond frames and masks
JPEG_AFTER = 300  # as ingest: PNG frames up to this many, JPEG (quality 95) beyond


@dataclass(frozen=True)
class DatasetImportResult:
    """What an import made.

    Fields:
        root: the project folder. num_frames, width, height: the project's frames.
        detected: frames whose keypoints MediaPipe found (0 with detection off).
        splits: split label -> number of project frames with it.
        replaced: an existing project was replaced.
        warnings: sentences worth showing a user.
        extras: what the dataset callback wrote (e.g. novel-view frame counts).
    """

    root: Path
    num_frames: int
    width: int
    height: int
    detected: int
    splits: dict
    replaced: bool
    warnings: tuple[str, ...]
    extras: dict


class MaskedKeypoints:
    """Keypoints for frames whose person mask is known: MediaPipe on a square crop around it."""

    def __init__(self, detect: bool, max_side: int = TrackerConfig().max_side):
        self.detector = MediaPipeDetector(mirror_average=True) if detect else None  # as `morf ingest`
        self.max_side = max_side

    def label(self, rgb: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, bool, str]:
        """(23, 3) points in pixels, found, source ("mediapipe" | "none")."""
        empty = np.zeros((NUM_KEYPOINTS, 3), np.float32)
        if self.detector is None:
            return empty, False, "none"
        box = mask_box(mask)
        if box is None:
            return empty, False, "none"
        h, w = mask.shape
        det = detect_in_region(self.detector, rgb, expand_box(box, 1.3, w, h, square=True), self.max_side)
        return (det.points, True, "mediapipe") if det.found else (empty, False, "none")

    def close(self) -> None:
        if self.detector is not None:
            self.detector.close()


def write_dataset_project(root: str | Path, frames: Iterable[DatasetFrame], *, total: int, camera: PinholeCamera,
                          fps: float | None, source: dict, record: dict, detect: bool = True, force: bool = False,
                          frame_format: str = "auto",
                          write_extras: Callable[[Path, list[int]], dict] | None = None,
                          control: StageControl | None = None, warnings: list[str] | None = None) -> DatasetImportResult:
    """Write ``frames`` (``total`` of them, all of ``camera``'s size) as the capture project ``root``.

    ``record`` is stored in the manifest under "dataset", completed with ``source_frames``
    and ``splits`` (one label per project frame). ``write_extras(dataset_dir, source_frames)``
    writes reference files into the staged ``PROJECT/dataset/`` and returns a summary dict.
    Raises MorfError (one line) on bad input; the target is then unchanged.
    """
    control = control or StageControl()
    root = Path(root)
    if frame_format not in ("auto", "png", "jpg"):
        raise InputError(f"frame format must be png, jpg or auto, got {frame_format!r}")
    replaced = check_replaceable(root, force)
    ext = "." + (frame_format if frame_format != "auto" else ("jpg" if total > JPEG_AFTER else "png"))
    warnings = warnings if warnings is not None else []  # extras may add to it
    points, found, kinds, source_frames, splits = [], [], [], [], []
    labeller = MaskedKeypoints(detect)
    try:
        with staged_folder(root) as staging:
            with FrameWriter(staging, ext, "import", "importing", total, control) as out, closing(labeller):
                for n, fr in out.numbered(frames):
                    if fr.rgb.shape[:2] != (camera.height, camera.width) or fr.mask.shape != fr.rgb.shape[:2]:
                        raise InputError(f"frame {fr.source_index}: image {fr.rgb.shape[1]}x{fr.rgb.shape[0]} and mask "
                                         f"{fr.mask.shape[1]}x{fr.mask.shape[0]} do not match the camera's "
                                         f"{camera.width}x{camera.height}")
                    p, ok, kind = labeller.label(fr.rgb, fr.mask)
                    out.write(n, fr.rgb, fr.mask)
                    points.append(p), found.append(ok), kinds.append(kind)
                    source_frames.append(int(fr.source_index)), splits.append(fr.split)
            if not source_frames:
                raise InputError("no frames were selected for import (check --split, --every and --max-frames)")
            if detect and not any(found):  # nothing to fit: an error, as for 'morf ingest', and no project left
                raise InputError(f"MediaPipe found no person in any of the {len(found)} imported frames; check that "
                                 "the dataset folder and subject are right (the frames should show one person)")
            extras = write_extras(staging / DATASET_DIR, source_frames) if write_extras else {}
            kp = Keypoints2D(np.stack(points).astype(np.float32), np.array(found, bool), np.array(kinds, str))
            full = dict(record, source_frames=source_frames, splits=splits, warnings=warnings,
                        keypoints_from="mediapipe" if detect else "none", masks_from="dataset", extras=extras)
            project = CaptureProject.create(staging, num_frames=len(source_frames), width=camera.width,
                                            height=camera.height, fps=fps, source=source, camera=camera,
                                            extra={"frame_ext": ext, "dataset": full})
            project.save_keypoints(kp)
            project.save_manifest()  # last, so a manifest always describes complete outputs
    except OSError as e:
        raise ProjectError(f"writing the project {root} failed: {e}") from None
    counts = {s: splits.count(s) for s in sorted(set(splits))}
    return DatasetImportResult(root, len(source_frames), camera.width, camera.height, int(sum(found)), counts,
                               replaced, tuple(warnings), extras)
