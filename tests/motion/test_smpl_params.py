"""SMPL / SMPL-X parameters split by body part (``global_orient``, ``body_pose``, ``transl``, ...):
told by their keys, read as the same motion as the AMASS files hold, fingers onto Anny's fingers,
and every bad number refused in one line."""

import numpy as np
import pytest

from morf.errors import InputError
from morf.io import load_npz
from morf.motion import RetargetConfig, load_motion
from morf.motion.formats import npz_motion_kind
from morf.motion.smpl_params import rotation_frames
from morf.motion.so3 import rotvec_to_matrix
from motion_files import smpl_body_motion, write_amass_smplh, write_amass_smplx
from smpl_param_files import (hand_motion, write_single_fit, write_smpl_matrices, write_smpl_params,
                              write_smplx_params)

RAW = RetargetConfig(fps=None, keep_feet_on_ground=False)


def _kind(path):
    return npz_motion_kind(load_npz(path, skip_pickled=True))


def _amass_smplx_with(path, hands=None, jaw=None):
    """The AMASS SMPL-X fixture with ``hands`` (T, 90) / ``jaw`` (T, 3) in both of its layouts."""
    src = load_npz(write_amass_smplx(path), skip_pickled=True)
    poses = src["poses"].copy()
    if hands is not None:
        poses[:, 75:] = hands
        src["pose_hand"] = hands
    if jaw is not None:
        poses[:, 66:69] = jaw
        src["pose_jaw"] = jaw
    np.savez(path, **{**src, "poses": poses})
    return path


def test_told_by_their_keys(tmp_path):
    for write in (write_smpl_params, write_smplx_params, write_smpl_matrices, write_single_fit):
        assert _kind(write(tmp_path / f"{write.__name__}.npz")) == "smpl-params", write.__name__
    assert _kind(write_amass_smplx(tmp_path / "x_stageii.npz")) == "amass"  # its own split keys stay AMASS


def test_split_smpl_is_exactly_the_amass_motion(tmp_path, body_model):
    """The AMASS fixture's motion in the split layout (same numbers, float64 as AMASS stores them)
    gives the very same clip: same rotations, same translations, bit for bit."""
    amass = load_motion(write_amass_smplh(tmp_path / "walk_poses.npz", fps=120.0), body_model)
    split = load_motion(write_smpl_params(tmp_path / "walk.npz", dtype=np.float64), body_model, source_fps=120.0)
    assert split.num_frames == amass.num_frames > 1 and "smpl-params:walk.npz (smpl, z-up)" in split.source
    assert np.array_equal(split.rotvecs, amass.rotvecs) and np.array_equal(split.transl, amass.transl)
    assert split.notes == () and amass.notes == ()


def test_a_rate_in_the_file_wins_and_30_fps_without(tmp_path, body_model):
    assert load_motion(write_smpl_params(tmp_path / "a.npz", fps=np.array(24.0)), body_model, config=RAW).fps == 24.0
    assert load_motion(write_smpl_params(tmp_path / "b.npz"), body_model, config=RAW).fps == 30.0


def test_float32_estimates_in_camera_space(tmp_path, body_model):
    """A video estimate's world is Y down: it is found and turned upright, and the float32 numbers
    give the AMASS motion to float32 precision."""
    amass = load_motion(write_amass_smplh(tmp_path / "w_poses.npz", fps=30.0), body_model, config=RAW)
    cam = load_motion(write_smpl_params(tmp_path / "cam.npz", camera=True), body_model, config=RAW)
    assert "y-up" in cam.source
    np.testing.assert_allclose(cam.rotvecs, amass.rotvecs, atol=1e-4)
    np.testing.assert_allclose(cam.transl, amass.transl, atol=1e-4)


def test_rotation_matrices_equal_axis_angle(tmp_path, body_model):
    body, _ = smpl_body_motion(24)
    np.savez(tmp_path / "aa.npz", global_orient=body[:, :3].astype(np.float32),
             body_pose=np.concatenate([body[:, 3:], np.zeros((24, 6))], axis=1).astype(np.float32))
    aa = load_motion(tmp_path / "aa.npz", body_model, config=RAW)
    mats = load_motion(write_smpl_matrices(tmp_path / "m.npz"), body_model, config=RAW)
    np.testing.assert_allclose(mats.rotvecs, aa.rotvecs, atol=1e-5)
    np.testing.assert_allclose(mats.transl, aa.transl, atol=1e-5)


def test_split_smplx_with_hands_is_the_amass_smplx_motion(tmp_path, body_model):
    hands = hand_motion(24)
    amass = load_motion(_amass_smplx_with(tmp_path / "h_stageii.npz", hands), body_model)
    split = load_motion(write_smplx_params(tmp_path / "h.npz", dtype=np.float64, hands=hands), body_model,
                        source_fps=60.0)
    assert np.array_equal(split.rotvecs, amass.rotvecs) and np.array_equal(split.transl, amass.transl)
    assert "map smpl-hands" in split.source
    # The AMASS file's own split keys (root_orient, pose_body, pose_hand) read the same.
    arrays = load_npz(tmp_path / "h_stageii.npz", skip_pickled=True)
    del arrays["poses"]
    np.savez(tmp_path / "parts_stageii.npz", **arrays)
    parts = load_motion(tmp_path / "parts_stageii.npz", body_model)
    assert np.array_equal(parts.rotvecs, amass.rotvecs)


@pytest.mark.parametrize("column,bone", [
    (0, "finger2-1.L"), (3, "finger2-2.L"), (9, "finger3-1.L"), (18, "finger5-1.L"), (27, "finger4-1.L"),
    (36, "finger1-1.L"), (42, "finger1-3.L"), (45, "finger2-1.R"), (81, "finger1-1.R"),
])
def test_each_finger_joint_turns_its_anny_finger_bone(tmp_path, body_model, column, bone):
    """One SMPL-X finger joint bent by 0.6 rad bends one Anny bone by 0.6 rad (its axis turned into
    Anny's axes) and nothing else; the body is the same as without hands."""
    T = 3
    hands = np.zeros((T, 90))
    hands[:, column:column + 3] = [0.0, 0.0, 0.6]
    bent = load_motion(write_smplx_params(tmp_path / "bent.npz", T=T, dtype=np.float64, hands=hands), body_model,
                       config=RAW)
    still = load_motion(write_smplx_params(tmp_path / "still.npz", T=T, dtype=np.float64), body_model, config=RAW)
    names = list(body_model.bone_names)
    angle = np.linalg.norm(bent.rotvecs, axis=-1)
    np.testing.assert_allclose(angle[:, names.index(bone)], 0.6, atol=1e-5)
    others = [i for i, n in enumerate(names) if n != bone]
    np.testing.assert_allclose(bent.rotvecs[:, others], still.rotvecs[:, others], atol=1e-5)
    assert not np.any(still.rotvecs[:, [i for i, n in enumerate(names) if n.startswith("finger")]])


def test_zero_hands_leave_the_rest_hand_and_a_still_face_says_nothing(tmp_path, body_model):
    clip = load_motion(write_smplx_params(tmp_path / "z.npz", dtype=np.float64), body_model, source_fps=60.0)
    amass = load_motion(write_amass_smplx(tmp_path / "z_stageii.npz"), body_model)
    assert np.array_equal(clip.rotvecs, amass.rotvecs) and clip.notes == ()


def test_a_moving_jaw_is_noted_not_played(tmp_path, body_model):
    jaw = np.zeros((24, 3))
    jaw[:, 0] = 0.3
    split = load_motion(write_smplx_params(tmp_path / "j.npz", dtype=np.float64, jaw=jaw), body_model,
                        source_fps=60.0)
    amass = load_motion(_amass_smplx_with(tmp_path / "j_stageii.npz", jaw=jaw), body_model)
    for clip in (split, amass):
        assert len(clip.notes) == 1 and "jaw" in clip.notes[0] and "no jaw bone" in clip.notes[0]
    still = load_motion(write_smplx_params(tmp_path / "s.npz", dtype=np.float64), body_model, source_fps=60.0)
    assert np.array_equal(split.rotvecs, still.rotvecs)


def test_a_single_image_fit_with_pca_hands(tmp_path, body_model):
    clip = load_motion(write_single_fit(tmp_path / "fit.npz"), body_model, config=RAW)
    assert clip.num_frames == 1
    assert len(clip.notes) == 1 and "'left_hand_pose' and 'right_hand_pose' hold 12 PCA coefficients" in clip.notes[0]
    assert "rest pose" in clip.notes[0]
    fingers = [i for i, n in enumerate(body_model.bone_names) if n.startswith("finger")]
    assert not np.any(clip.rotvecs[:, fingers])
    whole = load_motion(write_smpl_params(tmp_path / "whole.npz", dtype=np.float64), body_model, config=RAW)
    np.testing.assert_allclose(clip.rotvecs[0, 1:], whole.rotvecs[5, 1:], atol=1e-5)  # the same body pose


def test_one_frame_without_its_frame_axis(tmp_path, body_model):
    body, trans = smpl_body_motion(24)
    np.savez(tmp_path / "one.npz", global_orient=body[5, :3], body_pose=body[5, 3:], transl=trans[5])
    assert load_motion(tmp_path / "one.npz", body_model, config=RAW).num_frames == 1


def test_rotation_shapes():
    assert rotation_frames((7, 69), 23) == [("axis-angle", 7)]
    assert rotation_frames((7, 23, 3), 23) == [("axis-angle", 7)]
    assert rotation_frames((7, 23, 3, 3), 23) == [("matrices", 7)]
    assert rotation_frames((69,), 23) == [("axis-angle", 1)]
    assert rotation_frames((7, 69), 21) == []
    assert rotation_frames((7, 1, 3, 3), 1) == [("matrices", 7)]
    assert ("axis-angle", 3) in rotation_frames((3, 3), 1) and ("matrices", 1) in rotation_frames((3, 3), 1)


def test_three_frames_of_global_orient_are_not_one_matrix(tmp_path, body_model):
    """A (3, 3) global_orient is three axis-angle frames when body_pose has three frames."""
    body, trans = smpl_body_motion(3)
    np.savez(tmp_path / "three.npz", global_orient=body[:, :3], body_pose=np.zeros((3, 69)), transl=trans)
    assert load_motion(tmp_path / "three.npz", body_model, config=RAW).num_frames == 3


def _bad(tmp_path, **change):
    body, trans = smpl_body_motion(6)
    arrays = dict(global_orient=body[:, :3], body_pose=np.concatenate([body[:, 3:], np.zeros((6, 6))], axis=1),
                  transl=trans, betas=np.zeros((1, 10)))
    arrays.update(change)
    np.savez(tmp_path / "bad.npz", **arrays)
    return tmp_path / "bad.npz"


def _nan_at(frame, shape, value=np.nan):
    a = np.zeros(shape)
    a[frame, 4] = value
    return a


def _not_rotations():
    m = np.broadcast_to(np.eye(3), (6, 23, 3, 3)).copy()
    m[2, 4] = np.diag([1.0, 1.0, -1.0])  # a mirror
    return m


@pytest.mark.parametrize("change,words", [
    ({"body_pose": _nan_at(3, (6, 69))}, ["'body_pose' is NaN at frame 3", "fix or cut that frame"]),
    ({"global_orient": np.full((6, 3), 1e30)}, ["'global_orient' is 1e+30 rad at frame 0"]),
    ({"transl": np.full((6, 3), np.inf)}, ["'transl' is inf at frame 0"]),
    ({"body_pose": _not_rotations()}, ["'body_pose' holds a 3x3 matrix that is not a rotation at frame 2"]),
    ({"global_orient": np.zeros((5, 3))}, ["'global_orient' has shape (5, 3); expected (6, 3)"]),
    ({"body_pose": np.zeros((6, 50))}, ["'body_pose' has shape (6, 50)", "(T, 69) SMPL or (T, 63) SMPL-X"]),
    ({"transl": np.zeros((7, 3))}, ["'transl' has shape (7, 3); expected (6, 3)"]),
    ({"body_pose": np.array(["a"] * 69)}, ["'body_pose' holds <U1 values, not numbers"]),
    ({"left_hand_pose": np.full((6, 45), np.nan)}, ["'left_hand_pose' is NaN at frame 0"]),
    ({"jaw_pose": np.full((6, 3), np.nan)}, ["'jaw_pose' is NaN at frame 0"]),
    ({"expression": np.full((6, 10), np.inf)}, ["'expression' is inf at frame 0"]),
])
def test_bad_files_are_one_line(tmp_path, body_model, change, words):
    with pytest.raises(InputError) as e:
        load_motion(_bad(tmp_path, **change), body_model)
    text = str(e.value)
    assert "\n" not in text and text.startswith(str(tmp_path / "bad.npz"))
    for w in words:
        assert w in text, text
