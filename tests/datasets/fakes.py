"""Tiny People-Snapshot and ZJU-MoCap folders in the datasets' own layouts, for the tests."""

from __future__ import annotations

import pickle
from pathlib import Path

import cv2
import numpy as np

W, H = 96, 80


def person_box(i: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of frame i's bright "person" rectangle: it moves one step per frame."""
    x0 = 10 + 3 * i
    return x0, 15, x0 + 24, 70


def person_frame(i: int, w: int = W, h: int = H) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 3) uint8 BGR frame and (H, W) uint8 0/1 mask of frame i."""
    img = np.full((h, w, 3), 30, np.uint8)
    mask = np.zeros((h, w), np.uint8)
    x0, y0, x1, y1 = person_box(i)
    img[y0:y1, x0:x1] = (200, 220, 240)
    mask[y0:y1, x0:x1] = 1
    return img, mask


def make_people_snapshot(root: Path, subject: str, n: int = 12, *, camera_k=(0, 0, 0, 0, 0),
                         camera_rt=(0.0, 0.0, 0.0), camera_t=(0.0, 0.3, 2.5)) -> Path:
    """<root>/<subject>/ with <subject>.mp4, masks.hdf5, camera.pkl, reconstructed_poses.hdf5, consensus.pkl."""
    import h5py

    folder = root / subject
    folder.mkdir(parents=True)
    writer = cv2.VideoWriter(str(folder / f"{subject}.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 30, (W, H))
    masks = []
    for i in range(n):
        img, mask = person_frame(i)
        writer.write(img)
        masks.append(mask)
    writer.release()
    with h5py.File(folder / "masks.hdf5", "w") as f:
        f.create_dataset("masks", data=np.stack(masks))
    camera = {"camera_f": np.array([110.0, 112.0]), "camera_c": np.array([47.0, 41.0]),
              "camera_k": np.array(camera_k, float), "camera_rt": np.array(camera_rt, float),
              "camera_t": np.array(camera_t, float), "width": W, "height": H}
    (folder / "camera.pkl").write_bytes(pickle.dumps(camera, protocol=2))  # Python 2 era protocol
    rng = np.random.default_rng(0)
    with h5py.File(folder / "reconstructed_poses.hdf5", "w") as f:
        f.create_dataset("betas", data=rng.normal(size=10).astype(np.float32))
        f.create_dataset("pose", data=rng.normal(size=(n, 72)).astype(np.float32))
        f.create_dataset("trans", data=rng.normal(size=(n, 3)).astype(np.float32))
    consensus = {"betas": rng.normal(size=10), "v_personal": rng.normal(size=(6890, 3)) * 0.01}
    (folder / "consensus.pkl").write_bytes(pickle.dumps(consensus, protocol=2))
    return folder


def zju_camera(k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Camera k of the fake rig: K (3, 3), R (3, 3), T (3, 1) in millimetres."""
    K = np.array([[100.0 + k, 0, 48], [0, 101.0 + k, 40], [0, 0, 1]])
    a = 0.3 * k
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    T = np.array([[10.0 * k], [-20.0], [3000.0 + k]])
    return K, R, T


def make_zju(root: Path, subject: str = "387", n: int = 8, cams: int = 3) -> Path:
    """<root>/CoreView_<subject>/ with annots.npy, Camera_B<k>/, mask/, mask_cihp/, new_params/."""
    folder = root / f"CoreView_{subject}"
    Ks, Rs, Ts, Ds, ims = [], [], [], [], []
    for k in range(cams):
        K, R, T = zju_camera(k)
        Ks.append(K), Rs.append(R), Ts.append(T), Ds.append(np.zeros((5, 1)))
    for i in range(n):
        row = []
        for k in range(cams):
            rel = f"Camera_B{k + 1}/{i:06d}.jpg"
            img, mask = person_frame(i + k)
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(folder / rel), img)
            # the two mask folders each hold half of the person: the import must take their union
            top, bottom = mask.copy(), mask.copy()
            top[H // 2:] = 0
            bottom[:H // 2] = 0
            for d, m in (("mask", top), ("mask_cihp", bottom)):
                p = folder / d / f"Camera_B{k + 1}" / f"{i:06d}.png"
                p.parent.mkdir(parents=True, exist_ok=True)
                cv2.imwrite(str(p), m)  # values 0/1, as in the dataset
            row.append(rel)
        ims.append({"ims": row})
        params = {"poses": np.full((1, 72), i, np.float32), "Rh": np.zeros((1, 3)), "Th": np.full((1, 3), 0.1 * i),
                  "shapes": np.ones((1, 10))}
        (folder / "new_params").mkdir(exist_ok=True)
        np.save(folder / "new_params" / f"{i}.npy", np.array(params, dtype=object), allow_pickle=True)
    annots = {"cams": {"K": Ks, "R": Rs, "T": Ts, "D": Ds}, "ims": ims}
    np.save(folder / "annots.npy", np.array(annots, dtype=object), allow_pickle=True)
    return folder


class RunsCommand:
    """Unpickling this runs ``touch <marker>``: what a malicious pickle does."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        import os

        return (os.system, (f"touch {self.marker}",))
