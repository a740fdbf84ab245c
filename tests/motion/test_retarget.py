import numpy as np
import pytest
import torch

from morf.body.model import BodyPose
from morf.motion.anny_rest import FootPointEvaluator, target_rest
from morf.motion.convert import RetargetConfig, retarget
from morf.motion.retargeting import retarget_rotations, turn_and_shift
from morf.motion.skeleton import SourceMotion
from morf.motion.so3 import axis_rotation
from morf.motion.validate import direction_errors
from motion_helpers import tpose_motion


def _joints(model, rotvecs, transl=None):
    rv = torch.as_tensor(np.asarray(rotvecs), dtype=torch.float32)
    tr = torch.zeros(rv.shape[0], 3) if transl is None else torch.as_tensor(np.asarray(transl), dtype=torch.float32)
    with torch.no_grad():
        out = model(BodyPose(rv, tr), model.default_shape())
    return out.joints.numpy(), out.keypoints3d.numpy()


def _dir(J, names, a, b):
    v = J[:, names.index(b)] - J[:, names.index(a)]
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.fixture(scope="module")
def rest(body_model):
    return target_rest(body_model)


def test_zero_pose_is_an_a_pose(body_model, rest):
    d = _dir(rest.heads[None], list(rest.names), "upperarm01.L", "lowerarm01.L")[0]
    assert np.degrees(np.arcsin(-d[2])) > 30  # the rest arm hangs well below horizontal


def test_tpose_source_lifts_anny_arms_horizontal(body_model, rest):
    r = retarget_rotations(tpose_motion(), rest)
    J, _ = _joints(body_model, r.rotvecs)
    names = list(body_model.bone_names)
    for s, sign in (("L", 1.0), ("R", -1.0)):
        for a, b in ((f"upperarm01.{s}", f"lowerarm01.{s}"), (f"lowerarm01.{s}", f"wrist.{s}")):
            d = _dir(J, names, a, b)[0]
            assert abs(d[2]) < 0.03 and sign * d[0] > 0.99, (a, d)
    # Legs straight down, the person still facing -Y (the spine leans neither way much).
    thigh = _dir(J, names, "upperleg01.L", "lowerleg01.L")[0]
    assert thigh[2] < -0.99


def test_left_elbow_bend_stays_left(body_model, rest):
    src = tpose_motion(frames=1)
    j = src.skeleton.index("LeftForeArm")
    local = src.local_rotations.copy()
    local[0, j] = axis_rotation("y", -90.0)  # Y-up source: forearm from +X (left) to +Z (forwards)
    src = SourceMotion(src.skeleton, local, src.root_positions, src.fps, "y", "bend", "test")
    r = retarget_rotations(src, rest)
    J, _ = _joints(body_model, r.rotvecs)
    names = list(body_model.bone_names)
    fore_l = _dir(J, names, "lowerarm01.L", "wrist.L")[0]
    upper_l = _dir(J, names, "upperarm01.L", "lowerarm01.L")[0]
    fore_r = _dir(J, names, "lowerarm01.R", "wrist.R")[0]
    assert fore_l[1] < -0.99  # Anny's forward is -Y
    assert np.degrees(np.arccos(np.dot(fore_l, upper_l))) == pytest.approx(90.0, abs=1.0)
    assert fore_r[0] < -0.99  # the right arm did not move
    assert J[0, names.index("wrist.L"), 0] > 0.3  # the bent arm is still on the person's left


def test_random_source_rotations_give_exact_limb_directions(body_model, rest):
    """Anny composes rotations as assumed (M_child = M_parent D_child): limbs follow any source pose."""
    src = tpose_motion(frames=6)
    rng = np.random.default_rng(1)
    local = src.local_rotations.copy()
    for j in range(src.skeleton.num_joints):
        local[:, j] = [axis_rotation("x", a) @ axis_rotation("y", b) @ axis_rotation("z", c)
                       for a, b, c in rng.uniform(-40, 40, size=(6, 3))]
    src = SourceMotion(src.skeleton, local, src.root_positions, src.fps, "y", "random", "test")
    r = turn_and_shift(retarget_rotations(src, rest), True, True)
    err = direction_errors(r, src.skeleton.names, body_model)
    limbs = [v for k, v in err.items() if k not in ("spine", "mean")]
    assert max(limbs) < 0.05
    assert err["spine"] < 15.0


def test_retarget_keeps_feet_on_the_ground_and_resamples(body_model):
    src = tpose_motion(frames=12, fps=120.0)
    clip = retarget(src, body_model, config=RetargetConfig(fps=30.0))
    assert clip.fps == 30.0 and clip.num_frames == 3
    feet = FootPointEvaluator(body_model)(clip.poses(slice(None)))
    lowest = feet[..., 2].min(dim=1).values
    assert torch.all(lowest.abs() < 2e-3)
    assert np.allclose(clip.transl[0, :2], 0.0, atol=1e-6)  # centred


def test_source_facing_another_way_is_turned_to_face_forward(body_model):
    src = tpose_motion(frames=2)
    turn = axis_rotation("y", 90.0)  # the source now faces +X in its Y-up world
    local = src.local_rotations.copy()
    local[:, 0] = turn
    src = SourceMotion(src.skeleton, local, src.root_positions, src.fps, "y", "turned", "test")
    clip = retarget(src, body_model, config=RetargetConfig(fps=None, keep_feet_on_ground=False))
    J, _ = _joints(body_model, clip.rotvecs)
    names = list(body_model.bone_names)
    hips = J[0, names.index("upperleg01.L")] - J[0, names.index("upperleg01.R")]
    assert hips[0] > 0.15 and abs(hips[1]) < 0.01  # left hip on +X again: facing -Y


def test_amass_upright_source(body_model, rest, tmp_path):
    from morf.motion.amass import read_amass

    T = 3
    poses = np.zeros((T, 156))
    poses[:, 0] = np.pi / 2  # SMPL (Y up) stood up in AMASS's Z-up world, facing -Y
    np.savez(tmp_path / "a.npz", poses=poses, trans=np.zeros((T, 3)), mocap_framerate=np.array(60.0),
             gender=np.bytes_(b"neutral"))
    src = read_amass(tmp_path / "a.npz")
    r = retarget_rotations(src, rest)
    # No turn about the vertical; only a few degrees of pitch where SMPL's and Anny's spines differ.
    assert np.abs(r.rotvecs[:, 0, 1:]).max() < 0.01 and np.abs(r.rotvecs[:, 0, 0]).max() < 0.1
    J, _ = _joints(body_model, r.rotvecs)
    d = _dir(J, list(body_model.bone_names), "upperarm01.L", "lowerarm01.L")[0]
    assert d[0] > 0.98  # SMPL's T-pose arms


def test_fast_foot_points_match_the_full_model(body_model):
    rng = np.random.default_rng(2)
    pose = BodyPose(torch.as_tensor(rng.normal(scale=0.2, size=(3, 104, 3)), dtype=torch.float32),
                    torch.as_tensor(rng.normal(size=(3, 3)), dtype=torch.float32))
    fast = FootPointEvaluator(body_model)(pose)
    with torch.no_grad():
        full = body_model(pose, body_model.default_shape()).keypoints3d[:, 17:23]
    assert torch.allclose(fast, full, atol=1e-5)


def test_cmu_direction_errors(body_model, rest, shared_data):
    from morf.motion.bvh import read_bvh

    src = read_bvh(shared_data / "motion/cmu/01_01.bvh")
    r = retarget_rotations(src, rest)
    err = direction_errors(r, src.skeleton.names, body_model, frames=np.arange(0, src.num_frames, 200))
    assert max(v for k, v in err.items() if k not in ("spine", "mean")) < 0.05
    assert err["spine"] < 8.0
