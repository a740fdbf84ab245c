"""People-Snapshot (Alldieck et al. 2018) subjects -> capture projects.

Layout of one subject folder (as read by InstantAvatar's
``scripts/peoplesnapshot/preprocess_PeopleSnapshot.py``)::

    <subject>/<subject>.mp4           the turning-in-place video (1080x1080)
    <subject>/masks.hdf5              "masks": (N, H, W) uint8, non-zero = person
    <subject>/camera.pkl              Python 2 pickle of a dict: camera_f (2,), camera_c (2,),
                                      camera_k (5,) OpenCV distortion, camera_rt (3,) Rodrigues
                                      and camera_t (3,) world-to-camera, width, height
    <subject>/reconstructed_poses.hdf5  SMPL: "betas" (10,), "pose" (N, 72), "trans" (N, 3)
    <subject>/consensus.pkl           SMPL consensus shape: "betas", "v_personal" (6890, 3)

Frames and masks are undistorted with camera_k (as InstantAvatar does). The SMPL files are
kept as reference only, in ``PROJECT/dataset/smpl.npz``: our body model is Anny, so the
project is fitted with ``morf fit`` like any capture.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from morf.capture.video import open_video
from morf.datasets.frames import DatasetFrame, camera_from_opencv, distortion, undistort
from morf.datasets.safe_pickle import load_plain_pickle
from morf.datasets.splits import select_frames
from morf.datasets.writer import DatasetImportResult, write_dataset_project
from morf.errors import InputError
from morf.io import atomic_write_json, save_npz
from morf.pipeline.control import StageControl

# InstantAvatar's split (confs/dataset/peoplesnapshot/<subject>.yaml): (start, end, skip) with an
# inclusive end, applied to the video's frame indices. male-2-* test frames lie inside the
# training range (InstantAvatar evaluates those two on training poses).
SPLITS: dict[str, dict[str, tuple[int, int, int]]] = {
    "male-3-casual": {"train": (0, 455, 4), "test": (456, 675, 4)},
    "male-4-casual": {"train": (0, 659, 6), "test": (660, 872, 6)},
    "female-3-casual": {"train": (0, 445, 4), "test": (446, 647, 4)},
    "female-4-casual": {"train": (0, 335, 4), "test": (335, 523, 4)},
    "male-2-casual": {"train": (1, 455, 4), "test": (1, 455, 20)},
    "male-2-sport": {"train": (1, 455, 4), "test": (1, 455, 20)},
    "male-3-sport": {"train": (1, 230, 2), "test": (230, 460, 6)},
    "female-4-sport": {"train": (1, 336, 4), "test": (336, 524, 4)},
}


@dataclass(frozen=True)
class PeopleSnapshotConfig:
    """What to import from one People-Snapshot subject."""

    subject: str | None = None  # subject folder name (default: the source folder's own name)
    split: str = "train"  # "train" | "test" | "all" (every frame; labels kept in the manifest)
    max_frames: int | None = None  # keep at most this many frames (after --every)
    every: int = 1  # keep every k-th frame of the split
    detect: bool = True  # run MediaPipe for 2D keypoints (else frames are marked undetected)
    force: bool = False  # replace a project that already has fits / runs / an avatar
    frame_format: str = "auto"  # "png" | "jpg" | "auto"


def locate_subject(src: str | Path, subject: str | None) -> tuple[Path, str]:
    """(subject folder, subject name) from the dataset root or a subject folder."""
    src = Path(src)
    if not src.is_dir():
        raise InputError(f"People-Snapshot folder not found: {src}")
    if subject is None:
        return src, src.name
    if (src / subject).is_dir():
        return src / subject, subject
    if src.name == subject:
        return src, subject
    raise InputError(f"subject folder not found: {src / subject}")


def read_camera(path: Path):
    """camera.pkl -> (PinholeCamera, distortion coefficients or None)."""
    d = load_plain_pickle(path)
    if not isinstance(d, dict):
        raise InputError(f"{path}: expected a dict, got {type(d).__name__}")
    need = ("camera_f", "camera_c", "camera_rt", "camera_t", "width", "height")
    missing = [k for k in need if k not in d]
    if missing:
        raise InputError(f"{path}: missing {', '.join(missing)}")
    try:
        f, c = np.asarray(d["camera_f"], float).reshape(2), np.asarray(d["camera_c"], float).reshape(2)
        rt, t = np.asarray(d["camera_rt"], float).reshape(3), np.asarray(d["camera_t"], float).reshape(3)
        w, h = int(np.asarray(d["width"]).item()), int(np.asarray(d["height"]).item())
    except (ValueError, TypeError) as e:
        raise InputError(f"{path}: malformed camera values ({e})") from None
    K = np.array([[f[0], 0, c[0]], [0, f[1], c[1]], [0, 0, 1]])
    R = cv2.Rodrigues(rt.reshape(3, 1))[0]
    camera = camera_from_opencv(K, R, t, w, h, str(path))
    return camera, distortion(d.get("camera_k"))


def _h5py():
    try:
        import h5py
    except ImportError:
        raise InputError("reading People-Snapshot's .hdf5 files needs h5py: pip install h5py") from None
    return h5py


def _open_masks(path: Path, width: int, height: int):
    if not path.is_file():
        raise InputError(f"file not found: {path}")
    h5py = _h5py()
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise InputError(f"not a readable HDF5 file: {path} ({e})") from None
    if "masks" not in f or len(f["masks"].shape) != 3:
        f.close()
        raise InputError(f"{path}: expected a dataset 'masks' of shape (N, H, W)")
    n, h, w = f["masks"].shape
    if (h, w) != (height, width):
        f.close()
        raise InputError(f"{path}: masks are {w}x{h} but camera.pkl says {width}x{height}")
    return f


def import_people_snapshot(src: str | Path, project: str | Path, config: PeopleSnapshotConfig = PeopleSnapshotConfig(),
                           control: StageControl | None = None) -> DatasetImportResult:
    """Import one People-Snapshot subject into the capture project ``project``.

    Raises MorfError (one line, naming the file) on missing or malformed files, a refused
    pickle, or a subject without a published split (unless ``split="all"``).
    """
    folder, subject = locate_subject(src, config.subject)
    camera, dist = read_camera(folder / "camera.pkl")
    video = open_video(folder / f"{subject}.mp4")
    if (video.width, video.height) != (camera.width, camera.height):
        raise InputError(f"{video.path}: frames are {video.width}x{video.height} but camera.pkl says "
                         f"{camera.width}x{camera.height}")
    masks_file = _open_masks(folder / "masks.hdf5", camera.width, camera.height)
    try:
        n_masks = masks_file["masks"].shape[0]
        n = min(n_masks, video.frame_count or n_masks)
        warnings = []
        if video.frame_count and video.frame_count != n_masks:
            warnings.append(f"{video.frame_count} video frames but {n_masks} masks; using the first {n}")
        chosen, labels = select_frames(SPLITS.get(subject), config.split, n, config.every, config.max_frames,
                                       f"People-Snapshot subject {subject!r}")
        record = {"dataset": "people-snapshot", "subject": subject, "split": config.split,
                  "split_definition": SPLITS.get(subject), "split_from": "InstantAvatar",
                  "undistorted": dist is not None, "distortion": None if dist is None else dist.tolist()}

        def frames():
            wanted = dict(zip(chosen, labels))
            last = chosen[-1] if chosen else -1
            for fr in video.frames():
                if fr.index > last:
                    break
                if fr.index in wanted:
                    mask = np.asarray(masks_file["masks"][fr.index]) > 0
                    rgb, mask = undistort(fr.rgb, mask, camera, dist)
                    yield DatasetFrame(rgb, mask, fr.index, wanted[fr.index])
            if video.decoded <= last:
                raise InputError(f"{video.path}: only {video.decoded} frames could be decoded, "
                                 f"frame {last} is needed")

        def extras(out: Path, source_frames: list[int]) -> dict:
            return _write_reference(folder, out, subject, source_frames, warnings)

        return write_dataset_project(
            project, frames(), total=len(chosen), camera=camera, fps=None if video.fps is None else video.fps / config.every,
            source={"kind": "people-snapshot", "path": str(folder.resolve()), "subject": subject, "fps": video.fps},
            record=record, detect=config.detect, force=config.force, frame_format=config.frame_format,
            write_extras=extras, control=control, warnings=warnings)
    finally:
        masks_file.close()


def _write_reference(folder: Path, out: Path, subject: str, source_frames: list[int], warnings: list[str]) -> dict:
    """SMPL poses / consensus shape into ``out/smpl.npz`` (reference only); the split into split.json."""
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "split.json", {"dataset": "people-snapshot", "subject": subject,
                                           "definition": SPLITS.get(subject), "end_inclusive": True,
                                           "from": "InstantAvatar confs/dataset/peoplesnapshot"})
    arrays: dict[str, np.ndarray] = {}
    poses = folder / "reconstructed_poses.hdf5"
    if poses.is_file():
        h5py = _h5py()
        try:
            with h5py.File(poses, "r") as f:
                pose, trans = np.asarray(f["pose"], np.float32), np.asarray(f["trans"], np.float32)
                betas = np.asarray(f["betas"], np.float32)
        except (OSError, KeyError) as e:
            raise InputError(f"{poses}: expected datasets 'pose', 'trans', 'betas' ({e})") from None
        if pose.ndim != 2 or pose.shape[1] != 72 or trans.shape != (len(pose), 3):
            raise InputError(f"{poses}: expected pose (N, 72) and trans (N, 3), got {pose.shape}, {trans.shape}")
        idx = np.asarray(source_frames)
        ok = idx < len(pose)
        if not ok.all():
            warnings.append(f"reconstructed_poses.hdf5 covers {len(pose)} frames; later frames have no SMPL reference")
        arrays.update(smpl_pose=pose[np.minimum(idx, len(pose) - 1)], smpl_trans=trans[np.minimum(idx, len(pose) - 1)],
                      smpl_valid=ok, smpl_betas=betas.reshape(-1))
    consensus = folder / "consensus.pkl"
    if consensus.is_file():
        try:
            c = load_plain_pickle(consensus)
            if isinstance(c, dict):
                for k in ("betas", "v_personal"):
                    if k in c:
                        arrays[f"consensus_{k}"] = np.asarray(c[k], np.float32)
        except InputError as e:  # reference only: a refused or damaged file does not stop the import
            warnings.append(f"skipped consensus.pkl: {e}")
    if arrays:
        arrays["source_frames"] = np.asarray(source_frames, np.int64)
        save_npz(out / "smpl.npz", **arrays)
    return {"smpl_reference": bool(arrays)}
