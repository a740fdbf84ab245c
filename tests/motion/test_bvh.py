import numpy as np
import pytest

from morf.errors import InputError
from morf.motion.bvh import read_bvh
from morf.motion.skeleton import UNITS, forward_kinematics
from morf.motion.so3 import euler_to_matrix
from motion_helpers import TPOSE_JOINTS, write_bvh

N_JOINTS = len(TPOSE_JOINTS)


def test_parse_synthetic_file(tmp_path):
    path = tmp_path / "t.bvh"
    write_bvh(path, frames=4, fps=60.0)
    m = read_bvh(path)
    assert m.skeleton.num_joints == N_JOINTS and m.num_frames == 4 and m.fps == 60.0
    assert m.channel_orders[0] == "ZYX" and m.channel_orders[1] == "XYZ" and m.channel_orders[2] == "ZXY"
    assert m.channel_orders[m.skeleton.index("Head_end")] == ""
    assert m.skeleton.up_axis == "y" and "cm" in m.source
    # End sites become joints named after their parent.
    assert "Head_end" in m.skeleton.names and "LeftToeBase_end" in m.skeleton.names
    assert m.root_positions[0, 1] == pytest.approx(0.95)


def test_rotation_order_per_joint(tmp_path):
    path = tmp_path / "r.bvh"
    total = write_bvh(path, frames=1, child_order="XYZ")
    m0 = read_bvh(path)
    values = np.zeros((1, total))
    values[0, 1] = 95.0
    values[0, 6:9] = m0.skeleton.offsets[1] * 100  # Spine's position channels
    # LeftForeArm's three angles (X, Y, Z order in the file): find its column.
    names = [n for n, _, _ in TPOSE_JOINTS if not n.endswith("_End")]
    col = 6 + 6 + 3 * (names.index("LeftForeArm") - 2)
    values[0, col:col + 3] = [30.0, 40.0, 50.0]
    write_bvh(path, values=values, child_order="XYZ")
    m = read_bvh(path)
    j = m.skeleton.index("LeftForeArm")
    rx, ry, rz = (euler_to_matrix(np.array([a, 0, 0]), o) for a, o in ((30, "XYZ"), (40, "YXZ"), (50, "ZXY")))
    assert np.allclose(m.local_rotations[0, j], rx @ ry @ rz, atol=1e-9)
    # Forward kinematics moves the hand by the forearm's rotation about its head.
    _, X = forward_kinematics(m)
    hand, fore = m.skeleton.index("LeftHand"), j
    assert np.allclose(X[0, hand] - X[0, fore], rx @ ry @ rz @ np.array([0.25, 0, 0]), atol=1e-9)


@pytest.mark.parametrize("unit", ["m", "cm", "inch", "mm"])
def test_unit_detected_from_height(tmp_path, unit):
    path = tmp_path / f"{unit}.bvh"
    write_bvh(path, scale=0.01 / UNITS[unit])  # the same body written in ``unit``
    m = read_bvh(path)
    assert f"({unit}," in m.source
    assert np.allclose(m.root_positions[0], [0, 0.95, 0], atol=1e-4)
    assert np.linalg.norm(m.skeleton.offsets[m.skeleton.index("LeftLeg")]) == pytest.approx(0.42, abs=1e-4)


def test_z_up_file(tmp_path):
    path = tmp_path / "z.bvh"
    write_bvh(path, z_up=True)
    m = read_bvh(path)
    assert m.skeleton.up_axis == "z" and m.up_axis == "z"


def test_explicit_unit_and_bad_unit(tmp_path):
    path = tmp_path / "t.bvh"
    write_bvh(path)
    assert read_bvh(path, unit="m").root_positions[0, 1] == pytest.approx(95.0)
    with pytest.raises(InputError):
        read_bvh(path, unit="furlong")


@pytest.mark.parametrize("text", [
    "", "HELLO\n", "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n}\n",
    "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n1 2 3\n",
    "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Wrotation\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n1 2 3\n",
    "HIERARCHY\nROOT a\n{\nOFFSET 0 0 zero\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n\n",
])
def test_bad_files_give_input_errors(tmp_path, text):
    path = tmp_path / "bad.bvh"
    path.write_text(text)
    with pytest.raises(InputError):
        read_bvh(path)


def test_missing_file(tmp_path):
    with pytest.raises(InputError):
        read_bvh(tmp_path / "nope.bvh")


def test_cmu_01_01(shared_data):
    m = read_bvh(shared_data / "motion/cmu/01_01.bvh")
    real = [n for n in m.skeleton.names if not n.endswith("_end")]
    assert len(real) == 31 and real[:3] == ["Hips", "LHipJoint", "LeftUpLeg"]
    assert m.num_frames == 2752 and m.fps == 120.0
    assert set(o for o in m.channel_orders if o) == {"ZYX"}
    assert "(cmu, y-up)" in m.source  # CMU's unit: 1/0.45 inch
    # Hips about 0.95 m above the floor in the first frame.
    assert 0.85 < m.root_positions[0, 1] < 1.05


def test_cmu_131_old_names_and_scaled_copy(shared_data):
    a = read_bvh(shared_data / "motion/cmu/131_01.bvh")
    b = read_bvh(shared_data / "motion/cmu/scaled_131_01.bvh")
    assert "LeftHip" in a.skeleton.names and "lowerback" in a.skeleton.names and "Chest2" in a.skeleton.names
    assert a.num_frames == 994 and b.num_frames == 995
    assert "(m, y-up)" in b.source and "(cmu, y-up)" in a.source
    # The same skeleton in metres either way (the scaled copy rounds to micrometres).
    assert np.allclose(a.skeleton.offsets, b.skeleton.offsets, atol=2e-4)
    assert np.allclose(a.root_positions[0], b.root_positions[0], atol=2e-4)
