"""Tiny motion files laid out exactly like the public ones (same keys, shapes, dtypes), all
holding one and the same SMPL body motion, so the readers can be checked against each other.

- AMASS SMPL-H (``*_poses.npz``): trans, gender (bytes), mocap_framerate, betas (16), dmpls,
  poses (T, 156), marker_data;
- AMASS SMPL-X (``*_stageii.npz``): gender (str), surface_model_type, mocap_frame_rate,
  mocap_time_length, markers_latent, latent_labels, markers_latent_vids (a pickled dict, as
  published), trans, poses (T, 165), betas, num_betas, root_orient, pose_body, pose_hand,
  pose_jaw, pose_eye;
- AIST++ (``motions/*.pkl`` saved as .npz): smpl_loss, smpl_poses (T, 72), smpl_scaling (1,),
  smpl_trans (T, 3) in the scaled units, Y up, no frame rate;
- a capture's ``fits/fits.npz`` through the fits writer, poses in the camera's world (Y down).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.motion.amass import SMPL_REST
from morf.motion.so3 import axis_rotation, matrix_to_rotvec, rotvec_to_matrix

# AMASS is Z up, AIST++ Y up: Z-up world -> Y-up world is -90 degrees about X (z -> y, y -> -z).
Z_TO_Y_UP = axis_rotation("x", -90.0)


def smpl_body_motion(T: int = 24, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A smooth SMPL body motion in a Z-up world (AMASS's): (T, 66) root + 21 body joints axis-angle,
    (T, 3) trans, metres. The body stands upright, turns a little and walks along +X."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, T)[:, None]
    body = np.zeros((T, 66))
    a, b = rng.normal(scale=0.25, size=(2, 63))
    body[:, 3:] = a * np.sin(2 * np.pi * t) + b * t
    yaw = 0.4 * t[:, 0]
    stand = axis_rotation("x", 90.0)  # SMPL's Y-up rest stood up in a Z-up world
    body[:, :3] = matrix_to_rotvec(rotvec_to_matrix(yaw[:, None] * np.array([0.0, 0.0, 1.0])) @ stand)
    trans = np.stack([0.8 * t[:, 0], 0.1 * t[:, 0], 0.95 + 0.02 * np.sin(6 * t[:, 0])], axis=1) - SMPL_REST[0]
    return body, trans


def write_amass_smplh(path: Path, T: int = 24, fps: float = 120.0) -> Path:
    body, trans = smpl_body_motion(T)
    poses = np.concatenate([body, np.zeros((T, 90))], axis=1)  # + 2 x 15 hand joints
    np.savez(path, trans=trans, gender=np.array(b"male"), mocap_framerate=np.array(fps), betas=np.zeros(16),
             dmpls=np.zeros((T, 8)), poses=poses, marker_data=np.zeros((T, 41, 3)))
    return path


def write_amass_smplx(path: Path, T: int = 24, fps: float = 60.0) -> Path:
    body, trans = smpl_body_motion(T)
    jaw, eyes, hands = np.zeros((T, 3)), np.zeros((T, 6)), np.zeros((T, 90))
    poses = np.concatenate([body, jaw, eyes, hands], axis=1)  # 55 joints: root, body, jaw, eyes, hands
    labels = np.array(["C7", "CLAV", "LFHD", "RFHD"])
    np.savez(path, gender=np.array("female"), surface_model_type=np.array("smplx"),
             mocap_frame_rate=np.array(fps), mocap_time_length=np.array(T / fps), markers_latent=np.zeros((4, 3)),
             latent_labels=labels,
             markers_latent_vids=np.array({str(k): i for i, k in enumerate(labels)}, dtype=object),
             trans=trans, poses=poses, betas=np.zeros(16), num_betas=np.array(16), root_orient=body[:, :3],
             pose_body=body[:, 3:], pose_hand=hands, pose_jaw=jaw, pose_eye=eyes)
    return path


def write_aist(path: Path, T: int = 24, scaling: float = 93.0) -> Path:
    """The same motion as AIST++ stores it: Y up, translations times ``smpl_scaling``."""
    body, trans = smpl_body_motion(T)
    root = Z_TO_Y_UP @ rotvec_to_matrix(body[:, :3])
    pelvis = (trans + SMPL_REST[0]) @ Z_TO_Y_UP.T  # the pelvis lands at trans + rest pelvis
    poses = np.concatenate([matrix_to_rotvec(root), body[:, 3:], np.zeros((T, 6))], axis=1)
    np.savez(path, smpl_loss=np.array(1.5), smpl_poses=poses, smpl_scaling=np.array([scaling]),
             smpl_trans=(pelvis - SMPL_REST[0]) * scaling)
    return path


# A video capture's camera world: X right, Y down, Z forward, the person upright in front.
CAMERA_R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
CAMERA_T = np.array([0.1, 0.3, 3.0])


def write_capture_fits(root: Path, rotvecs: np.ndarray, transl: np.ndarray, fps: float = 30.0,
                       camera_world: bool = True):
    """A bare capture project ``root`` with fits of Anny poses ``rotvecs`` (T, 104, 3), ``transl``
    (T, 3) given in a Z-up world, stored as ``morf fit`` stores them (in the camera's world by default)."""
    from morf.capture.project import CaptureProject
    from morf.fitting.fits_io import BodyFits, save_fits

    T = rotvecs.shape[0]
    project = CaptureProject.create(root, num_frames=T, width=64, height=64, fps=fps, source={"kind": "test"})
    rot = np.asarray(rotvecs, np.float64).copy()
    t = np.asarray(transl, np.float64)
    if camera_world:
        rot[:, 0] = matrix_to_rotvec(CAMERA_R @ rotvec_to_matrix(rot[:, 0]))
        t = t @ CAMERA_R.T + CAMERA_T
    z = np.zeros(T, np.float32)
    fits = BodyFits(rotvecs=rot.astype(np.float32), transl=t.astype(np.float32),
                    shape=np.full((1, 6), 0.35, np.float32), keypoint_residual_px=z, keypoint_worst_px=z,
                    silhouette_iou=z, projected_keypoints=np.zeros((T, 23, 2), np.float32), config={"test": True})
    project.fits_dir.mkdir(parents=True, exist_ok=True)
    save_fits(project.fits_path, fits)
    return project
