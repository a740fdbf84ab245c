"""``morf motion export``: a clip as BVH, read back with a BVH parser we did not write (the ``bvh``
package from PyPI) and with our own reader, whose forward kinematics must pose Anny's joints."""

import bvh  # the test extra's independent BVH parser (pip install -e ".[test]")
import numpy as np
import pytest
import torch

from morf.cli.main import main
from morf.motion import RetargetConfig, load_motion
from morf.motion.bvh import read_bvh
from morf.motion.bvh_export import anny_bvh_skeleton, clip_channels
from morf.motion.skeleton import forward_kinematics, to_z_up
from motion_files import write_amass_smplx, write_capture_fits


def _check_against_clip(path, clip, model, shape, order="ZYX"):
    text = path.read_text()
    skeleton = anny_bvh_skeleton(model, shape)
    # A parser we did not write: joints, frames, frame time, channels and every value.
    other = bvh.Bvh(text)
    names = other.get_joints_names()
    assert len(names) == len(model.bone_names) == skeleton.num_joints
    assert names == [skeleton.names[j] for j in skeleton.file_order()]
    assert other.nframes == clip.num_frames == len(other.frames)
    assert other.frame_time == pytest.approx(1.0 / clip.fps, abs=1e-8)
    rot = [f"{a}rotation" for a in order]
    assert other.joint_channels(names[0]) == ["Xposition", "Yposition", "Zposition", *rot]
    assert all(other.joint_channels(n) == rot for n in names[1:])
    leg = skeleton.offsets[skeleton.names.index("upperleg01.L")]
    assert other.joint_offset("upperleg01.L") == pytest.approx(tuple(leg), abs=1e-6)
    values = np.array(other.frames, dtype=np.float64)
    np.testing.assert_allclose(values, clip_channels(clip, skeleton, order), atol=1.5e-6)
    # Our reader and its forward kinematics put every joint where the body model poses it.
    src = read_bvh(path)
    assert src.fps == clip.fps and src.num_frames == clip.num_frames and "(m, y-up)" in src.source
    _, X = forward_kinematics(src)
    X = X @ to_z_up(src.up_axis).T
    idx = [src.skeleton.names.index(n) for n in model.bone_names]
    with torch.no_grad():
        J = model(clip.poses(np.arange(clip.num_frames)), shape if shape is not None else model.default_shape()).joints
    np.testing.assert_allclose(X[:, idx], J.double().numpy(), atol=2e-5)


def test_export_cmu_bvh(shared_data, body_model, tmp_path, capsys):
    src = shared_data / "motion/cmu/131_01.bvh"
    out = tmp_path / "131.bvh"
    # 10 fps: the 8-second clip's 83 frames check the same file layout and values as 249 would,
    # and the export and the clip it is checked against each pose Anny once a frame
    assert main(["motion", "export", str(src), "--out", str(out), "--fps", "10"]) == 0
    assert "104 joints" in capsys.readouterr().out
    _check_against_clip(out, load_motion(src, body_model, None, RetargetConfig(fps=10.0)), body_model, None)


def test_export_amass_on_a_projects_body(body_model, tmp_path):
    project = write_capture_fits(tmp_path / "cap", np.zeros((3, 104, 3), np.float32), np.zeros((3, 3), np.float32))
    shape = torch.full((1, 6), 0.35)
    src = write_amass_smplx(tmp_path / "m_stageii.npz", T=16, fps=60.0)
    out = tmp_path / "m.bvh"
    assert main(["motion", "export", str(src), "--out", str(out), "--project", str(project.root),
                 "--rotation-order", "zxy", "--fps", "24"]) == 0
    clip = load_motion(src, body_model, shape, RetargetConfig(fps=24.0))
    assert clip.num_frames == 7
    _check_against_clip(out, clip, body_model, shape, "ZXY")
    # The project's body sets the bone lengths.
    default = anny_bvh_skeleton(body_model)
    own = anny_bvh_skeleton(body_model, shape)
    assert not np.allclose(default.offsets, own.offsets, atol=1e-3)


def test_export_bad_input_is_one_line(tmp_path, capsys):
    np.savez(tmp_path / "w.npz", weights=np.zeros(3))
    assert main(["motion", "export", str(tmp_path / "w.npz"), "--out", str(tmp_path / "o.bvh")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a motion: found weights (3,)" in err[0]
    assert not (tmp_path / "o.bvh").exists()
