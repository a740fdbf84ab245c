import numpy as np
import pytest

from morf.errors import InputError
from morf.motion.amass import SMPL_REST, read_amass
from morf.motion.so3 import rotvec_to_matrix


def _write(path, width, T=5, fps_key="mocap_framerate", gender=np.bytes_(b"female"), **extra):
    rng = np.random.default_rng(0)
    poses = rng.normal(scale=0.2, size=(T, width))
    trans = np.cumsum(rng.normal(scale=0.01, size=(T, 3)), axis=0)
    np.savez(path, poses=poses, trans=trans, betas=np.zeros(16), gender=gender, **{fps_key: np.array(60.0)}, **extra)
    return poses, trans


@pytest.mark.parametrize("width,kind", [(156, "smplh"), (165, "smplx")])
def test_read_smplh_and_smplx(tmp_path, width, kind):
    path = tmp_path / f"{kind}.npz"
    poses, trans = _write(path, width)
    m = read_amass(path)
    assert m.kind == kind and m.num_frames == 5 and m.fps == 60.0 and m.up_axis == "z"
    assert m.skeleton.up_axis == "y" and "female" in m.source
    j = m.skeleton.index("left_elbow")  # body joint 18 -> pose columns 54:57
    assert np.allclose(m.local_rotations[:, j], rotvec_to_matrix(poses[:, 54:57]))
    assert np.allclose(m.local_rotations[:, 0], rotvec_to_matrix(poses[:, :3]))
    assert np.allclose(m.root_positions, trans + SMPL_REST[0])


def test_gender_as_str_and_other_frame_rate_key(tmp_path):
    path = tmp_path / "a.npz"
    _write(path, 156, fps_key="mocap_frame_rate", gender=np.str_("male"))
    m = read_amass(path)
    assert m.fps == 60.0 and "male" in m.source


def test_split_smplx_keys(tmp_path):
    path = tmp_path / "s.npz"
    np.savez(path, root_orient=np.zeros((3, 3)), pose_body=np.zeros((3, 63)), trans=np.zeros((3, 3)),
             mocap_frame_rate=np.array(30.0))
    assert read_amass(path).num_frames == 3


@pytest.mark.parametrize("arrays", [
    {"poses": np.zeros((4, 100)), "trans": np.zeros((4, 3))},
    {"poses": np.zeros((4, 156)), "trans": np.zeros((3, 3))},
    {"poses": np.full((4, 156), np.nan), "trans": np.zeros((4, 3))},
    {"something": np.zeros(3)},
])
def test_bad_arrays(tmp_path, arrays):
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(InputError):
        read_amass(path)


def test_pickled_arrays_are_never_loaded(tmp_path):
    # Public SMPL-X files carry a pickled marker dict beside plain arrays: it is left out, not unpickled.
    path = tmp_path / "p.npz"
    np.savez(path, poses=np.zeros((2, 156)), trans=np.zeros((2, 3)), gender=np.array({"x": 1}, dtype=object))
    assert "neutral" in read_amass(path).source
    np.savez(path, poses=np.array([{"x": 1}] * 2, dtype=object), trans=np.zeros((2, 3)))
    with pytest.raises(InputError, match="no 'poses'"):
        read_amass(path)
