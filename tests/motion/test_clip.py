import numpy as np
import pytest
import torch

from morf.errors import InputError
from morf.motion.clip import MotionClip, load_clip, resample, save_clip
from morf.motion.so3 import matrix_to_rotvec, rotvec_to_matrix


def _turning_clip(T=121, fps=120.0, J=4):
    """Bone 1 turns about Z at 90 deg/s; translation moves 1 m/s along -Y."""
    t = np.arange(T) / fps
    rot = np.zeros((T, J, 3), np.float32)
    rot[:, 1, 2] = np.radians(90.0) * t
    rot[:, 2] = [0.3, -0.2, 0.1]
    tr = np.stack([np.zeros(T), -t, np.full(T, 0.9)], axis=1).astype(np.float32)
    return MotionClip(rot, tr, fps, "turn", "test")


def test_pose_batches_and_indexing():
    clip = _turning_clip()
    p = clip.pose(3)
    assert p.rotvecs.shape == (1, 4, 3) and p.transl.shape == (1, 3) and p.rotvecs.dtype == torch.float32
    assert torch.allclose(p.rotvecs[0], torch.from_numpy(clip.rotvecs[3]))
    assert len(clip) == 121 and clip[-1].transl[0, 1] == pytest.approx(-1.0)
    assert clip.poses(np.arange(5, 9)).rotvecs.shape == (4, 4, 3)
    assert clip.frame_at(0.5) == 60 and clip.frame_at(1.02) == 1 and clip.frame_at(5.0, loop=False) == 120


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError):
        MotionClip(np.zeros((3, 4, 3)), np.zeros((2, 3)), 30.0)
    with pytest.raises(ValueError):
        MotionClip(np.zeros((3, 4, 3)), np.zeros((3, 3)), 0.0)


def test_resample_120_to_30_keeps_every_fourth_frame():
    clip = _turning_clip()
    out = resample(clip, 30.0)
    assert out.fps == 30.0 and out.num_frames == 31
    R_in = rotvec_to_matrix(clip.rotvecs[::4])
    R_out = rotvec_to_matrix(out.rotvecs)
    assert np.abs(R_in - R_out).max() < 1e-5
    assert np.allclose(out.transl, clip.transl[::4], atol=1e-6)


def test_resample_between_frames_slerps_and_lerps():
    clip = _turning_clip(T=5, fps=1.0)  # bone 1 at 0, 90, 180, 270, 360 degrees about Z
    out = resample(clip, 2.0)  # half-way frames
    assert out.num_frames == 9
    angle = np.degrees(np.linalg.norm(out.rotvecs[1, 1]))
    assert angle == pytest.approx(45.0, abs=1e-3)
    assert out.rotvecs[1, 1, 2] > 0  # the same turning direction
    assert out.transl[1, 1] == pytest.approx(-0.5)
    # The constant bone stays put.
    assert np.allclose(out.rotvecs[:, 2], clip.rotvecs[0, 2], atol=1e-6)


def test_save_load_roundtrip(tmp_path):
    clip = _turning_clip(T=7)
    save_clip(clip, tmp_path / "c.npz")
    back = load_clip(tmp_path / "c.npz")
    assert back.name == "turn" and back.source == "test" and back.fps == clip.fps
    assert np.array_equal(back.rotvecs, clip.rotvecs) and np.array_equal(back.transl, clip.transl)


def test_load_clip_rejects_other_npz(tmp_path):
    np.savez(tmp_path / "x.npz", a=np.zeros(3))
    with pytest.raises(InputError):
        load_clip(tmp_path / "x.npz")
    with pytest.raises(InputError):
        load_clip(tmp_path / "missing.npz")


def test_rotvec_matrix_roundtrip_near_pi():
    r = np.array([[0.0, 0.0, np.pi - 1e-4], [1e-9, 0, 0], [0.3, -1.2, 0.5]])
    back = matrix_to_rotvec(rotvec_to_matrix(r))
    assert np.allclose(rotvec_to_matrix(back), rotvec_to_matrix(r), atol=1e-8)
