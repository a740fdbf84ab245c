"""Motions for the player are MotionClips checked against the avatar's bone count."""

import numpy as np
import pytest

from morf.errors import InputError
from morf.io import save_npz
from morf.motion.clip import MotionClip
from morf.playback.motion_input import load_playback_motion


def test_anny_poses_load_as_a_float32_clip(tmp_path):
    rot = np.zeros((5, 104, 3))
    rot[:, 0, 2] = np.linspace(0.0, 1.0, 5)
    save_npz(tmp_path / "m.npz", rotvecs=rot, transl=np.zeros((5, 3)), fps=np.array(24.0))
    clip = load_playback_motion(tmp_path / "m.npz", 104)
    assert isinstance(clip, MotionClip) and clip.fps == 24.0 and clip.num_frames == 5
    assert clip.rotvecs.dtype == np.float32 and clip.transl.dtype == np.float32
    np.testing.assert_allclose(clip.rotvecs[:, 0, 2], np.linspace(0.0, 1.0, 5), atol=1e-6)


def test_wrong_bone_count_and_missing_file_are_input_errors(tmp_path):
    save_npz(tmp_path / "m.npz", rotvecs=np.zeros((3, 5, 3), np.float32), transl=np.zeros((3, 3), np.float32))
    with pytest.raises(InputError, match="motion must be"):
        load_playback_motion(tmp_path / "m.npz", 104)
    with pytest.raises(InputError, match="not found"):
        load_playback_motion(tmp_path / "none.npz", 104)
