"""The capture project folder: the unit a user works on.

Layout (format "morf-capture", version 1)::

    PROJECT/
      morf_project.json   manifest: version, source, frame count, image size, fps, camera,
                          frame_ext (".png" or ".jpg"), frame_times (optional: seconds of each
                          frame since the video's first, its presentation times; absent in
                          projects made from images, before PyAV decoding, or with --fps),
                          unordered_views (optional, true: the frames are photos of the person from
                          several sides in no particular order, e.g. images ingested without
                          --fps; no frame rate, no times, no neighbours), and an
                          "ingest" section (source frames, scale, people seen, where the focal
                          length came from, timing, rotation, warnings)
      frames/000000.png   RGB frames (PNG; JPEG for long videos)
      masks/000000.png    person masks, 0 or 255
      keypoints.npz       keypoints (N, 23, 3) x, y, confidence (COCO-17 + 6 feet);
                          detected (N,) bool; source (N,) str: mediapipe | openpose | ground_truth | none
      keypoints_hands_face.npz  OpenPose hand and face points, when imported
      review.json         the user's per-frame decisions: {"drop": [...], "keep": [...]}
      fits/               body fits and the automatic frame filter (morf fit; layout in
                          morf/fitting/project_fit.py, fits.npz read and written by morf/fitting/fits_io.py)
      runs/               training runs (morf train; morf/train/run_dir.py)
      avatar/             the exported avatar (morf export; morf/export/avatar_folder.py)
      dataset/            imported standard datasets only: reference files (not read by the pipeline)
      ground_truth/       synthetic captures only: camera, poses, shape, hold-out set
                          (full layout in morf/synth/capture.py; gt.npz and holdout.npz
                          read and written by morf/synth/ground_truth.py)

Every file is written atomically, so a killed command never leaves a damaged project, and
re-running a stage replaces its outputs whole.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.camera import PinholeCamera
from morf.capture.keypoint_layout import NUM_KEYPOINTS
from morf.errors import ProjectError
from morf.io import atomic_write_json, load_npz, read_image, save_npz, write_image

FORMAT = "morf-capture"
VERSION = 1
MANIFEST = "morf_project.json"
FITS_DIR = "fits"  # PROJECT/fits/: CaptureProject.fits_dir


@dataclass(frozen=True)
class Keypoints2D:
    """2D keypoints of every frame.

    Fields:
        points: (N, 23, 3) float32, x and y in pixels and a confidence in [0, 1].
        detected: (N,) bool, whether a person was found in the frame.
        source: (N,) str, where each frame's keypoints come from.
    """

    points: np.ndarray
    detected: np.ndarray
    source: np.ndarray

    def __post_init__(self):
        if self.points.ndim != 3 or self.points.shape[1:] != (NUM_KEYPOINTS, 3):
            raise ValueError(f"keypoints must be (N, {NUM_KEYPOINTS}, 3), got {self.points.shape}")


@dataclass(frozen=True)
class FrameDecision:
    """Whether a frame is used for training, and why not."""

    index: int
    used: bool
    reason: str | None  # e.g. "user", "no person detected", "keypoint residual 41 px"


MAX_SIDE = 16384  # pixels; a frame wider than this is no video frame
MAX_FRAMES = 10_000_000


def _number(value, low: float, high: float) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and low <= value <= high  # nan fails too


def check_manifest(manifest: dict, path: Path) -> None:
    """Every number of a project manifest that later stages use, checked once when it is opened:
    a hand-edited or damaged manifest is one line, not a crash (or a silent nonsense) later."""
    def bad(key: str, want: str):
        return ProjectError(f"damaged project manifest {path}: {key!r} must be {want}, got {manifest.get(key)!r}; "
                            "restore it, or make the project again with 'morf ingest'")

    for key, high in (("num_frames", MAX_FRAMES), ("width", MAX_SIDE), ("height", MAX_SIDE)):
        value = manifest.get(key)
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= high:
            raise bad(key, f"a whole number from 0 to {high}")
    if manifest.get("fps") is not None and not _number(manifest["fps"], 1e-3, 1e4):
        raise bad("fps", "a frame rate between 0.001 and 10000, or absent")
    unordered = manifest.get("unordered_views", False)
    if not isinstance(unordered, bool):
        raise bad("unordered_views", "true or false")
    if unordered and (manifest.get("fps") is not None or manifest.get("frame_times") is not None):
        raise ProjectError(f"damaged project manifest {path}: 'unordered_views' is true but the manifest also gives "
                           "a frame rate or frame times; remove one, or make the project again with 'morf ingest' "
                           "(with --fps for a clip, without it for a photo set)")
    if manifest.get("frame_ext", ".png") not in (".png", ".jpg"):
        raise bad("frame_ext", "'.png' or '.jpg'")
    cam = manifest.get("camera")
    if cam is not None:
        if not isinstance(cam, dict):
            raise bad("camera", "an object with fx, fy, cx, cy, width, height")
        for key in ("fx", "fy", "cx", "cy", "width", "height"):
            if not _number(cam.get(key), -1e7 if key in ("cx", "cy") else 1e-6, 1e7):
                raise ProjectError(f"damaged project manifest {path}: camera {key!r} must be a finite number"
                                   f"{'' if key in ('cx', 'cy') else ' above 0'}, got {cam.get(key)!r}")
        for key, shape in (("R", (3, 3)), ("t", (3,))):
            if key in cam:
                try:
                    a = np.asarray(cam[key], np.float64)
                except (TypeError, ValueError):
                    a = None
                if a is None or a.shape != shape or not np.isfinite(a).all():
                    raise ProjectError(f"damaged project manifest {path}: camera {key!r} must be {shape} finite numbers")


class CaptureProject:
    """A project folder on disk. Create with :meth:`create`, open with :meth:`open`."""

    def __init__(self, root: Path, manifest: dict):
        self.root = Path(root)
        self.manifest = manifest

    # ---- opening and creating -----------------------------------------------------------
    @staticmethod
    def is_project(root: str | Path) -> bool:
        return (Path(root) / MANIFEST).is_file()

    @classmethod
    def open(cls, root: str | Path) -> "CaptureProject":
        root = Path(root)
        if not root.exists():
            raise ProjectError(f"project folder not found: {root}")
        if not root.is_dir():
            raise ProjectError(f"not a folder: {root}")
        path = root / MANIFEST
        if not path.is_file():
            raise ProjectError(f"{root} is not a MoRF capture project (no {MANIFEST}); create one with 'morf ingest' or 'morf synth'")
        try:
            manifest = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ProjectError(f"damaged project manifest {path}: {e}") from None
        if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
            raise ProjectError(f"{path} is not a MoRF capture manifest")
        version = manifest.get("version")
        if not isinstance(version, int) or version > VERSION:
            raise ProjectError(f"project version {version!r} is newer than this MoRF understands ({VERSION}); update MoRF")
        check_manifest(manifest, path)
        return cls(root, manifest)

    @classmethod
    def create(cls, root: str | Path, *, num_frames: int, width: int, height: int, fps: float | None,
               source: dict, camera: PinholeCamera | None = None, extra: dict | None = None) -> "CaptureProject":
        """Write a fresh manifest (frames, masks and keypoints are written by the caller)."""
        root = Path(root)
        if root.exists() and not root.is_dir():
            raise ProjectError(f"not a folder: {root}")
        root.mkdir(parents=True, exist_ok=True)
        manifest = {
            "format": FORMAT, "version": VERSION,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "num_frames": int(num_frames), "width": int(width), "height": int(height),
            "fps": None if fps is None else float(fps),
            "source": source,
            "camera": None if camera is None else camera.to_dict(),
        }
        manifest.update(extra or {})
        project = cls(root, manifest)
        project.save_manifest()
        return project

    def save_manifest(self) -> None:
        atomic_write_json(self.root / MANIFEST, self.manifest)

    def update_manifest(self, **fields) -> None:
        self.manifest.update(fields)
        self.save_manifest()

    # ---- frames and masks ---------------------------------------------------------------
    @property
    def num_frames(self) -> int:
        return int(self.manifest["num_frames"])

    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) of every frame."""
        return int(self.manifest["width"]), int(self.manifest["height"])

    @property
    def fps(self) -> float | None:
        return self.manifest.get("fps")

    @property
    def unordered_views(self) -> bool:
        """The frames are views of the person in no particular order (a photo set): nothing may
        treat neighbouring frames as close in time."""
        return bool(self.manifest.get("unordered_views", False))

    def frame_times(self) -> np.ndarray | None:
        """(N,) float64 seconds of each frame since the source's first: the video's presentation
        times when ingest recorded them (variable frame rate clips), else index / fps; None when
        the project knows neither (images without --fps)."""
        times = self.manifest.get("frame_times")
        if times is not None:
            try:
                t = np.asarray(times, np.float64)
            except (TypeError, ValueError):
                t = None
            if t is None or t.shape != (self.num_frames,) or not np.isfinite(t).all():
                raise ProjectError(f"damaged project manifest {self.root / MANIFEST}: bad 'frame_times'")
            return t
        fps = self.fps
        return np.arange(self.num_frames, dtype=np.float64) / fps if fps else None

    @property
    def is_synthetic(self) -> bool:
        return self.ground_truth_dir.is_dir()

    def frame_path(self, i: int) -> Path:
        ext = self.manifest.get("frame_ext", ".png")
        return self.root / "frames" / f"{i:06d}{ext}"

    def mask_path(self, i: int) -> Path:
        return self.root / "masks" / f"{i:06d}.png"

    def load_frame(self, i: int) -> np.ndarray:
        """(H, W, 3) uint8 RGB."""
        self._check_index(i)
        return read_image(self.frame_path(i))

    def load_mask(self, i: int) -> np.ndarray:
        """(H, W) bool person mask."""
        self._check_index(i)
        return read_image(self.mask_path(i), grayscale=True) > 127

    def save_frame(self, i: int, rgb: np.ndarray) -> None:
        write_image(self.frame_path(i), rgb)

    def save_mask(self, i: int, mask: np.ndarray) -> None:
        write_image(self.mask_path(i), (np.asarray(mask) > 0).astype(np.uint8) * 255)

    def _check_index(self, i: int) -> None:
        if not 0 <= i < self.num_frames:
            raise IndexError(f"frame {i} out of range 0..{self.num_frames - 1}")

    # ---- camera -------------------------------------------------------------------------
    def camera(self) -> PinholeCamera:
        """The capture's camera: stored intrinsics, or a default focal length for the image size."""
        cam = self.manifest.get("camera")
        if cam:
            return PinholeCamera.from_dict(cam)
        w, h = self.image_size
        return PinholeCamera.default_for_image(w, h)

    # ---- keypoints ----------------------------------------------------------------------
    def save_keypoints(self, kp: Keypoints2D) -> None:
        save_npz(self.root / "keypoints.npz", points=kp.points.astype(np.float32),
                 detected=kp.detected.astype(bool), source=kp.source.astype(str))

    def load_keypoints(self) -> Keypoints2D:
        d = load_npz(self.root / "keypoints.npz")
        try:
            kp = Keypoints2D(d["points"].astype(np.float32), d["detected"].astype(bool), d["source"].astype(str))
        except (KeyError, ValueError) as e:
            raise ProjectError(f"damaged keypoints file in {self.root}: {e}") from None
        if kp.points.shape[0] != self.num_frames:
            raise ProjectError(f"keypoints cover {kp.points.shape[0]} frames, project has {self.num_frames}")
        return kp

    # ---- frame review: the user's decisions, and the automatic filter ---------------------
    def review_path(self) -> Path:
        return self.root / "review.json"

    def load_review(self) -> dict[str, list[int]]:
        p = self.review_path()
        if not p.is_file():
            return {"drop": [], "keep": []}
        try:
            d = json.loads(p.read_text())
            out = {k: d.get(k, []) for k in ("drop", "keep")}
        except (json.JSONDecodeError, UnicodeDecodeError, AttributeError) as e:
            raise ProjectError(f"damaged review file {p}: {e}; delete it to start the review afresh") from None
        for key, frames in out.items():
            if not isinstance(frames, list) or not all(isinstance(i, int) and not isinstance(i, bool)
                                                       and 0 <= i < self.num_frames for i in frames):
                raise ProjectError(f"damaged review file {p}: {key!r} must list frame numbers from 0 to "
                                   f"{self.num_frames - 1}; delete it to start the review afresh")
            out[key] = sorted(frames)
        return out

    def set_user_decision(self, i: int, decision: str | None) -> None:
        """Record the user's choice for frame i: "drop", "keep" (overrides the filter) or None."""
        self._check_index(i)
        if decision not in ("drop", "keep", None):
            raise ValueError(f"decision must be 'drop', 'keep' or None, got {decision!r}")
        r = self.load_review()
        for k in ("drop", "keep"):
            r[k] = [j for j in r[k] if j != i]
        if decision:
            r[decision] = sorted(r[decision] + [i])
        atomic_write_json(self.review_path(), r)

    def auto_filter(self) -> dict[int, str]:
        """Frames the automatic filter rejected, with the reason (empty before fitting)."""
        p = self.fits_dir / "filter.json"
        if not p.is_file():
            return {}
        try:
            d = json.loads(p.read_text())
            return {int(k): str(v) for k, v in d.get("rejected", {}).items()}
        except (json.JSONDecodeError, TypeError, ValueError, AttributeError) as e:
            raise ProjectError(f"damaged filter file {p}: {e}") from None

    def frame_decisions(self) -> list[FrameDecision]:
        """Per frame: used for training or not, and why. User choices override the filter."""
        review = self.load_review()
        drop, keep = set(review["drop"]), set(review["keep"])
        auto = self.auto_filter()
        kp_path = self.root / "keypoints.npz"
        detected = self.load_keypoints().detected if kp_path.is_file() else np.ones(self.num_frames, bool)
        out = []
        for i in range(self.num_frames):
            if i in drop:
                out.append(FrameDecision(i, False, "dropped by user"))
            elif i in keep:
                out.append(FrameDecision(i, True, None))
            elif i in auto:
                out.append(FrameDecision(i, False, auto[i]))
            elif not detected[i]:
                out.append(FrameDecision(i, False, "no person detected"))
            else:
                out.append(FrameDecision(i, True, None))
        return out

    def training_frames(self) -> list[int]:
        return [d.index for d in self.frame_decisions() if d.used]

    # ---- stage folders ------------------------------------------------------------------
    @property
    def fits_dir(self) -> Path:
        return self.root / FITS_DIR

    @staticmethod
    def fits_owner(path: str | Path) -> Path | None:
        """``ROOT`` when ``path`` names a file in ``ROOT``'s fits folder (``ROOT/fits/NAME``, like
        :attr:`fits_path`), else None. ``path`` is taken as given (resolve it first to follow links);
        ``ROOT`` need not be a project (:meth:`is_project` tells)."""
        path = Path(path)
        return path.parent.parent if path.parent.name == FITS_DIR else None

    @property
    def fits_path(self) -> Path:
        """``fits/fits.npz``: read and written only through :mod:`morf.fitting.fits_io`."""
        return self.fits_dir / "fits.npz"

    @property
    def runs_dir(self) -> Path:
        return self.root / "runs"

    @property
    def avatar_dir(self) -> Path:
        return self.root / "avatar"

    @property
    def ground_truth_dir(self) -> Path:
        """``ground_truth/``: what a synthetic capture knows to be true (written by :mod:`morf.synth.capture`)."""
        return self.root / "ground_truth"

    @property
    def ground_truth_path(self) -> Path:
        """``ground_truth/gt.npz``: read and written only through :mod:`morf.synth.ground_truth`."""
        return self.ground_truth_dir / "gt.npz"

    @property
    def holdout_path(self) -> Path:
        """``ground_truth/holdout.npz``: read and written only through :mod:`morf.synth.ground_truth`."""
        return self.ground_truth_dir / "holdout.npz"

    def holdout_frame_path(self, j: int) -> Path:
        """Image ``j`` of the synthetic hold-out sequence (see :mod:`morf.synth.ground_truth`)."""
        return self.ground_truth_dir / "holdout" / "frames" / f"{j:06d}.png"

    def holdout_mask_path(self, j: int) -> Path:
        """Mask ``j`` of the synthetic hold-out sequence, 0 or 255."""
        return self.ground_truth_dir / "holdout" / "masks" / f"{j:06d}.png"
