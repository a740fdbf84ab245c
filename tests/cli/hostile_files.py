"""Builders of the bad files the hostile-input suite hands to the commands: motions with NaN, inf
or 1e30, npz files that are text, pickles or bombs, broken BVH, OpenPose JSON and avatar manifests,
a checkpoint that runs code when unpickled, a video with nobody in it.

Each builder writes one file (or folder) from a good one, so a refused input is refused for the one
thing that was changed. Nothing here imports torch or morf: the files are made the way a user, or
an attacker, would make them.
"""

from __future__ import annotations

import io
import json
import os
import pickle
import zipfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
CLIP = REPO / "resources" / "motions" / "idle_sway.npz"  # a MoRF clip: rotvecs (120, 104, 3)
FRAMES = 8  # frames kept from the clip: enough to play, cheap to read


def good_poses() -> tuple[np.ndarray, np.ndarray]:
    """(rotvecs (8, 104, 3), transl (8, 3)) float32 of a shipped motion."""
    with np.load(CLIP) as z:
        return z["rotvecs"][:FRAMES].copy(), z["transl"][:FRAMES].copy()


def player_npz(path: Path, rotvecs=None, transl=None, **extra) -> Path:
    """Anny poses as the player reads them: rotvecs (T, 104, 3), transl (T, 3), fps."""
    r, t = good_poses()
    arrays = {"rotvecs": r if rotvecs is None else rotvecs, "transl": t if transl is None else transl, "fps": 30.0}
    arrays.update(extra)
    np.savez(path, **arrays)
    return path


def clip_npz(path: Path, rotvecs=None) -> Path:
    """A MoRF clip file (``morf_motion_version`` 1) holding ``rotvecs``."""
    r, t = good_poses()
    np.savez(path, morf_motion_version=np.int32(1), rotvecs=r if rotvecs is None else rotvecs, transl=t,
             fps=np.float64(30.0), name=np.str_("hostile"), source=np.str_("tests"))
    return path


def amass_npz(path: Path, nan_pose: bool = False, trans_scale: float = 1.0) -> Path:
    """An AMASS SMPL-H file (poses (T, 156), trans, mocap_framerate) standing still, with a NaN
    pose value or translations times ``trans_scale``."""
    poses = np.zeros((FRAMES, 156))
    poses[:, 0] = np.pi / 2  # upright in AMASS's Z-up world
    trans = np.tile([0.0, 0.0, 0.95], (FRAMES, 1)) * trans_scale
    if nan_pose:
        poses[3, 10] = np.nan
    np.savez(path, poses=poses, trans=trans, mocap_framerate=np.array(120.0), betas=np.zeros(16),
             gender=np.array(b"male"))
    return path


def npy_header(shape: tuple[int, ...], descr: str = "<f4") -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": descr, "fortran_order": False, "shape": shape})
    return buf.getvalue()


def npz_claiming_huge_array(path: Path) -> Path:
    """An .npz whose rotvecs member declares 10^9 x 104 x 3 floats (1.2 TB) and holds 64 bytes."""
    _, t = good_poses()
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("rotvecs.npy", npy_header((10**9, 104, 3)) + bytes(64))
        buf = io.BytesIO()
        np.save(buf, t)
        z.writestr("transl.npy", buf.getvalue())
    return path


def npz_deflate_bomb(path: Path, mib: int = 320) -> Path:
    """A real zip bomb of about 1.5 MB: rotvecs is ``mib`` MiB of zeros, deflated."""
    n = (mib << 20) // (104 * 3 * 4)
    _, t = good_poses()
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as z:
        with z.open("rotvecs.npy", "w", force_zip64=True) as f:
            f.write(npy_header((n, 104, 3)))
            left, chunk = n * 104 * 3 * 4, bytes(16 << 20)
            while left > 0:
                f.write(chunk[:min(left, len(chunk))])
                left -= len(chunk)
        buf = io.BytesIO()
        np.save(buf, np.tile(t[:1], (n, 1)))
        z.writestr("transl.npy", buf.getvalue())
    return path


def npz_with_only_objects(path: Path) -> Path:
    """An .npz whose arrays are pickled Python objects (numpy writes them with allow_pickle)."""
    np.savez(path, rotvecs=np.array([{"a": 1}, None], dtype=object), transl=np.array([[1, 2]], dtype=object))
    return path


class _RunsCode:
    """Unpickling this makes the folder named by ``marker``: a stand-in for any code at all."""

    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return (os.mkdir, (self.marker,))


def pickled_checkpoint(path: Path, marker: Path) -> Path:
    """A file laid out like ``torch.save``'s zip whose pickle calls ``os.mkdir(marker)``."""
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("archive/data.pkl", pickle.dumps({"state": _RunsCode(marker)}, protocol=2))
        z.writestr("archive/byteorder", "little")
        z.writestr("archive/version", "3\n")
    return path


# ----- BVH ------------------------------------------------------------------------------------

def bvh_parts(text: str) -> tuple[list[str], list[str], list[list[str]]]:
    """(hierarchy lines up to MOTION, the 'Frames:' and 'Frame Time:' lines, rows of values)."""
    lines = text.splitlines()
    m = lines.index("MOTION")
    return lines[:m + 1], lines[m + 1:m + 3], [row.split() for row in lines[m + 3:] if row.strip()]


def bvh_variant(good: Path, path: Path, *, value: str | None = None, frame_time: str | None = None,
                frames: str | None = None, rows: int | None = None, offset: str | None = None,
                cut_at: float | None = None) -> Path:
    """``good`` with one change: ``value`` put in the 4th channel of frame 2, the Frame Time or the
    Frames count replaced, only ``rows`` rows of data, the second OFFSET's first number replaced,
    or the whole text cut at fraction ``cut_at``."""
    text = good.read_text()
    if cut_at is not None:
        path.write_text(text[: int(len(text) * cut_at)])
        return path
    head, timing, data = bvh_parts(text)
    data = data[:FRAMES] if rows is None else data[:rows]
    if value is not None:
        data[2][3] = value
    if offset is not None:
        k = [i for i, line in enumerate(head) if line.strip().startswith("OFFSET")][1]
        indent = head[k][: len(head[k]) - len(head[k].lstrip())]
        head[k] = f"{indent}OFFSET {offset} 0.0 0.0"
    n = len(data) if frames is None else frames
    ft = timing[1].split(":", 1)[1].strip() if frame_time is None else frame_time
    out = head + [f"Frames: {n}", f"Frame Time: {ft}"] + [" ".join(r) for r in data]
    path.write_text("\n".join(out) + "\n")
    return path


# ----- OpenPose -------------------------------------------------------------------------------

def openpose_person(frame: int) -> list[float]:
    """BODY_25 points (75 values) of a person standing in a 128 x 128 image, all confident."""
    # Nose, neck, shoulders/elbows/wrists, mid-hip, hips/knees/ankles, eyes, ears, feet.
    xy = [(64, 20), (64, 32), (54, 32), (50, 48), (48, 62), (74, 32), (78, 48), (80, 62), (64, 64),
          (58, 64), (57, 84), (56, 104), (70, 64), (71, 84), (72, 104), (62, 18), (66, 18), (60, 19),
          (68, 19), (74, 110), (75, 111), (72, 108), (54, 110), (53, 111), (56, 108)]
    out = []
    for x, y in xy:
        out += [float(x + 0.1 * frame), float(y), 0.9]
    return out


def openpose_folder(folder: Path, frames: int = 12, names: str = "{:06d}_keypoints.json",
                    change=None) -> Path:
    """One OpenPose JSON per frame; ``change(frame, doc) -> doc or text`` alters some of them."""
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(frames):
        doc = {"version": 1.3, "people": [{"person_id": [-1], "pose_keypoints_2d": openpose_person(i)}]}
        if change is not None:
            doc = change(i, doc)
        text = doc if isinstance(doc, str) else json.dumps(doc)
        (folder / names.format(i)).write_text(text)
    return folder


# ----- avatar folders and projects ------------------------------------------------------------

def edit_json(path: Path, change) -> None:
    """Rewrite the JSON file ``path`` as ``change(doc)`` returns it (NaN written as NaN)."""
    doc = json.loads(path.read_text())
    path.write_text(json.dumps(change(doc), indent=1))


def flip_byte(path: Path, at: float = 0.5) -> None:
    """Invert one byte of ``path``, at fraction ``at`` of its length (size and mtime stay plausible)."""
    data = bytearray(path.read_bytes())
    k = int(len(data) * at)
    data[k] ^= 0xFF
    path.write_bytes(bytes(data))


def video_without_person(path: Path, frames: int = 12, size: int = 96) -> Path:
    """A short grey clip with a slowly moving dark square and nobody in it."""
    import cv2

    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (size, size))
    try:
        for i in range(frames):
            img = np.full((size, size, 3), 128, np.uint8)
            img[20:40, 10 + 2 * i:30 + 2 * i] = 40
            writer.write(img)
    finally:
        writer.release()
    if not path.is_file() or path.stat().st_size == 0:
        raise RuntimeError(f"OpenCV wrote no video to {path}")
    return path
