"""ZJU-MoCap (Peng et al. 2021) sequences -> a monocular capture project plus novel views.

Layout of one sequence folder (``CoreView_<id>`` or ``my_<id>``), as read by Neural Body's
light-stage loaders and HumanNeRF's ``tools/prepare_zju_mocap/prepare_dataset.py``::

    annots.npy        np.save of a dict (a pickle inside a .npy):
                        cams: {K: [(3, 3)], D: [(5, 1)], R: [(3, 3)], T: [(3, 1) millimetres]}
                              one entry per camera, OpenCV world-to-camera
                        ims:  [{ims: [image path per camera, relative to the folder]}, ...] per frame
    Camera_B1/000000.jpg     or "Camera (1)/CoreView_313_Camera_(1)_0001_....jpg" (313, 315)
    mask/<image path>.png, mask_cihp/<image path>.png   person masks, non-zero = person; HumanNeRF
                                                       takes their union, so do we
    new_params/<i>.npy       SMPL per frame: dict poses (1, 72), Rh (1, 3), Th (1, 3), shapes (1, 10)

The chosen camera (default 1, the one HumanNeRF trains on) becomes the project's frames; the
other cameras' images of every ``view_every``-th project frame go to ``PROJECT/dataset/views/``
for novel-view evaluation, with their cameras. SMPL parameters are kept as reference only
(``PROJECT/dataset/smpl.npz``): the project is fitted with Anny by ``morf fit``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.datasets.frames import DatasetFrame, camera_from_opencv, distortion, undistort
from morf.datasets.safe_pickle import load_npy
from morf.datasets.writer import DatasetImportResult, write_dataset_project
from morf.errors import InputError
from morf.io import atomic_write_json, read_image, save_npz, write_image
from morf.pipeline.control import StageControl

# HumanNeRF's training frames per subject (tools/prepare_zju_mocap/<id>.yaml: training_view 0 =
# camera 1, the first max_frames frames; None = every frame).
HUMANNERF_FRAMES: dict[str, int | None] = {
    "313": 1000, "315": 2000, "377": 570, "386": 540, "387": 540, "390": None, "392": None, "393": None, "394": 475,
}
SPLITS = ("humannerf", "all")
MASK_DIRS = ("mask", "mask_cihp")
MM = 1000.0  # annots.npy translations are in millimetres


@dataclass(frozen=True)
class ZjuMocapConfig:
    """What to import from one ZJU-MoCap sequence."""

    camera: int = 1  # the training camera, 1-based as in "Camera (1)" / "Camera_B1"
    split: str = "humannerf"  # "humannerf": HumanNeRF's training frames; "all": every frame
    max_frames: int | None = None  # keep at most this many frames (after --every)
    every: int = 1  # keep every k-th frame
    view_every: int = 30  # store the other cameras' images of every k-th project frame (0: none)
    detect: bool = True  # run MediaPipe for 2D keypoints (else frames are marked undetected)
    force: bool = False  # replace a project that already has fits / runs / an avatar
    frame_format: str = "auto"  # "png" | "jpg" | "auto"


@dataclass(frozen=True)
class ZjuCameras:
    """All cameras of a sequence.

    Fields:
        K: (C, 3, 3) intrinsics; R: (C, 3, 3) world-to-camera; t: (C, 3) metres; D: (C, 5) distortion.
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    D: np.ndarray


def subject_id(folder: Path) -> str:
    """"CoreView_387" / "my_387" / "387" -> "387"."""
    m = re.search(r"(\d+)$", folder.name)
    return m.group(1) if m else folder.name


def read_annots(path: Path) -> tuple[ZjuCameras, list[list[str]]]:
    """annots.npy -> (cameras, image paths [frame][camera])."""
    arr = load_npy(path)
    d = arr.item() if arr.shape == () else None
    if not isinstance(d, dict) or "cams" not in d or "ims" not in d:
        raise InputError(f"{path}: expected a dict with 'cams' and 'ims'")
    cams = d["cams"]
    try:
        K = np.asarray(cams["K"], np.float64).reshape(-1, 3, 3)
        R = np.asarray(cams["R"], np.float64).reshape(-1, 3, 3)
        t = np.asarray(cams["T"], np.float64).reshape(-1, 3) / MM
        D = np.asarray(cams["D"], np.float64).reshape(len(K), -1) if "D" in cams else np.zeros((len(K), 5))
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"{path}: malformed 'cams' (want K, R, T, D lists per camera): {e}") from None
    if not len(K) == len(R) == len(t) == len(D):
        raise InputError(f"{path}: cams K, R, T, D have different numbers of cameras")
    ims = []
    for i, entry in enumerate(d["ims"]):
        paths = entry.get("ims") if isinstance(entry, dict) else None
        if not isinstance(paths, (list, tuple, np.ndarray)) or not all(isinstance(p, str) for p in paths):
            raise InputError(f"{path}: ims[{i}] must be a dict with a list of image paths under 'ims'")
        ims.append([str(p) for p in paths])
    if not ims:
        raise InputError(f"{path}: no frames in 'ims'")
    return ZjuCameras(K, R, t, D), ims


def _inside(folder: Path, rel: str) -> Path:
    """folder / rel, refusing paths that leave the folder (annots.npy is untrusted input)."""
    p = (folder / rel).resolve()
    if folder.resolve() not in p.parents:
        raise InputError(f"annots.npy names a file outside the sequence folder: {rel!r}")
    return p


def read_view(folder: Path, rel: str) -> tuple[np.ndarray, np.ndarray]:
    """One camera image and its mask (the union of mask/ and mask_cihp/): (H, W, 3) uint8, (H, W) bool."""
    rgb = read_image(_inside(folder, rel))
    mask, tried = None, []
    for d in MASK_DIRS:
        p = _inside(folder, str(Path(d) / Path(rel).with_suffix(".png")))
        tried.append(str(p))
        if p.is_file():
            m = read_image(p, grayscale=True) > 0
            if m.shape != rgb.shape[:2]:
                raise InputError(f"mask {p} is {m.shape[1]}x{m.shape[0]} but its image is {rgb.shape[1]}x{rgb.shape[0]}")
            mask = m if mask is None else mask | m
    if mask is None:
        raise InputError(f"no mask for {rel}: expected {' or '.join(tried)}")
    return rgb, mask


def smpl_index(image_path: str, frame: int) -> int:
    """new_params file number: 313 and 315 name it inside the image file name, others use the frame."""
    m = re.search(r"\)_(\d{4})", Path(image_path).name)
    return int(m.group(1)) if m else frame


def import_zju_mocap(src: str | Path, project: str | Path, config: ZjuMocapConfig = ZjuMocapConfig(),
                     control: StageControl | None = None) -> DatasetImportResult:
    """Import one ZJU-MoCap sequence folder into the capture project ``project`` (see module doc)."""
    folder = Path(src)
    if not folder.is_dir():
        raise InputError(f"ZJU-MoCap sequence folder not found: {folder}")
    if config.split not in SPLITS:
        raise InputError(f"--split must be one of {', '.join(SPLITS)}, got {config.split!r}")
    if config.every < 1 or (config.max_frames is not None and config.max_frames < 1) or config.view_every < 0:
        raise InputError("--every and --max-frames must be at least 1, --view-every at least 0")
    cams, ims = read_annots(folder / "annots.npy")
    c = config.camera - 1
    if not 0 <= c < len(cams.K):
        raise InputError(f"--camera {config.camera}: the sequence has cameras 1..{len(cams.K)}")
    if any(len(row) != len(cams.K) for row in ims):
        raise InputError(f"{folder / 'annots.npy'}: some frames list a different number of images than cameras")
    subject = subject_id(folder)
    warnings: list[str] = []
    limit = len(ims)
    if config.split == "humannerf":
        if subject not in HUMANNERF_FRAMES:
            warnings.append(f"no HumanNeRF frame count known for subject {subject}; using every frame")
        limit = min(len(ims), HUMANNERF_FRAMES.get(subject) or len(ims))
    chosen = list(range(limit))[::config.every][:config.max_frames]
    first = read_image(_inside(folder, ims[chosen[0]][c]))
    h, w = first.shape[:2]
    camera = camera_from_opencv(cams.K[c], cams.R[c], cams.t[c], w, h, f"annots.npy camera {config.camera}")
    dist = distortion(cams.D[c])

    def frames():
        for i in chosen:
            rgb, mask = read_view(folder, ims[i][c])
            rgb, mask = undistort(rgb, mask, camera, dist)
            yield DatasetFrame(rgb, mask, i, "train")

    def extras(out: Path, source_frames: list[int]) -> dict:
        summary = _write_smpl(folder, out, ims, c, source_frames, warnings)
        summary.update(_write_views(folder, out, cams, ims, c, source_frames, config.view_every, (w, h)))
        atomic_write_json(out / "split.json", {
            "dataset": "zju-mocap", "subject": subject, "split": config.split, "train_camera": config.camera,
            "train_frames": source_frames, "from": "HumanNeRF tools/prepare_zju_mocap/<subject>.yaml",
            "novel_view_frames_every": config.view_every})
        return summary

    record = {"dataset": "zju-mocap", "subject": subject, "split": config.split, "camera": config.camera,
              "frame_limit": limit, "split_from": "HumanNeRF", "undistorted": dist is not None,
              "distortion": None if dist is None else dist.tolist(), "cameras": len(cams.K)}
    return write_dataset_project(
        project, frames(), total=len(chosen), camera=camera, fps=None,
        source={"kind": "zju-mocap", "path": str(folder.resolve()), "subject": subject},
        record=record, detect=config.detect, force=config.force, frame_format=config.frame_format,
        write_extras=extras, control=control, warnings=warnings)


def _write_smpl(folder: Path, out: Path, ims, c: int, source_frames: list[int], warnings: list[str]) -> dict:
    params = next((folder / d for d in ("new_params", "params") if (folder / d).is_dir()), None)
    if params is None:
        warnings.append("no new_params/ folder: no SMPL reference stored")
        return {"smpl_reference": False}
    keys = {"poses": 72, "Rh": 3, "Th": 3, "shapes": 10}
    rows = {k: np.zeros((len(source_frames), n), np.float32) for k, n in keys.items()}
    valid = np.zeros(len(source_frames), bool)
    for j, i in enumerate(source_frames):
        p = params / f"{smpl_index(ims[i][c], i)}.npy"
        if not p.is_file():
            continue
        d = load_npy(p)
        d = d.item() if d.shape == () else None
        if not isinstance(d, dict) or any(k not in d for k in keys):
            raise InputError(f"{p}: expected a dict with {', '.join(keys)}")
        for k, n in keys.items():
            v = np.asarray(d[k], np.float32).reshape(-1)
            if v.size != n:
                raise InputError(f"{p}: {k} has {v.size} values, expected {n}")
            rows[k][j] = v
        valid[j] = True
    if not valid.all():
        warnings.append(f"{int((~valid).sum())} frames have no SMPL parameters in {params.name}/")
    out.mkdir(parents=True, exist_ok=True)
    save_npz(out / "smpl.npz", **rows, valid=valid, source_frames=np.asarray(source_frames, np.int64))
    return {"smpl_reference": True}


def _write_views(folder: Path, out: Path, cams: ZjuCameras, ims, c: int, source_frames: list[int],
                 every: int, size: tuple[int, int]) -> dict:
    """Other cameras' images of every ``every``-th project frame -> out/views/camera_XX/{frames,masks}."""
    if every == 0:
        return {"views": 0, "view_frames": 0}
    project_idx = list(range(0, len(source_frames), every))
    cameras = {}
    for k in range(len(cams.K)):
        if k == c:
            continue
        name = f"camera_{k + 1:02d}"
        cam = camera_from_opencv(cams.K[k], cams.R[k], cams.t[k], *size, f"annots.npy camera {k + 1}")
        dist = distortion(cams.D[k])
        for n, j in enumerate(project_idx):
            rgb, mask = read_view(folder, ims[source_frames[j]][k])
            if rgb.shape[:2] != (size[1], size[0]):
                raise InputError(f"{ims[source_frames[j]][k]} is {rgb.shape[1]}x{rgb.shape[0]}, camera {c + 1}'s "
                                 f"images are {size[0]}x{size[1]}")
            rgb, mask = undistort(rgb, mask, cam, dist)
            write_image(out / "views" / name / "frames" / f"{n:06d}.png", rgb)
            write_image(out / "views" / name / "masks" / f"{n:06d}.png", mask.astype(np.uint8) * 255)
        cameras[name] = {"camera": cam.to_dict(), "source_camera": k + 1,
                         "distortion_removed": None if dist is None else dist.tolist()}
    atomic_write_json(out / "views.json", {
        "project_frames": project_idx, "source_frames": [source_frames[j] for j in project_idx],
        "cameras": cameras})
    return {"views": len(cameras), "view_frames": len(project_idx)}
