import numpy as np
import pytest
import torch

from morf.errors import InputError
from morf.motion import MotionClip, load_motion, motion_library, save_clip
from morf.motion.anny_rest import FootPointEvaluator, target_rest
from morf.motion.procedural import idle_sway, walk_cycle
from motion_helpers import write_bvh


def test_bad_paths_and_contents(tmp_path):
    with pytest.raises(InputError, match="no such"):
        load_motion(tmp_path / "none.bvh")
    (tmp_path / "m.txt").write_text("x")
    with pytest.raises(InputError, match="not a motion file"):
        load_motion(tmp_path / "m.txt")
    np.savez(tmp_path / "other.npz", weights=np.zeros(3))
    with pytest.raises(InputError, match="not a motion"):
        load_motion(tmp_path / "other.npz")
    (tmp_path / "broken.npz").write_bytes(b"not a zip")
    with pytest.raises(InputError):
        load_motion(tmp_path / "broken.npz")
    (tmp_path / "broken.bvh").write_text("HIERARCHY\nROOT\n")
    with pytest.raises(InputError):
        load_motion(tmp_path / "broken.bvh")


def test_clip_file_loads_as_it_is(tmp_path):
    clip = MotionClip(np.zeros((4, 104, 3), np.float32), np.zeros((4, 3), np.float32), 24.0, "still", "test")
    save_clip(clip, tmp_path / "still.npz")
    back = load_motion(tmp_path / "still.npz")  # no body model needed
    assert back.fps == 24.0 and back.num_frames == 4 and back.name == "still"


def test_bvh_and_amass_are_retargeted(tmp_path, body_model):
    write_bvh(tmp_path / "t.bvh", frames=8, fps=120.0)
    clip = load_motion(tmp_path / "t.bvh", body_model)
    assert clip.rotvecs.shape == (2, 104, 3) and clip.fps == 30.0
    np.savez(tmp_path / "a.npz", poses=np.zeros((6, 165)), trans=np.zeros((6, 3)), mocap_frame_rate=np.array(30.0),
             gender=np.str_("female"))
    clip = load_motion(tmp_path / "a.npz", body_model)
    assert clip.num_frames == 6 and "smplx" in clip.source


def test_motion_library(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "b.bvh").write_text("")
    (tmp_path / "sub" / "a.npz").write_bytes(b"")
    (tmp_path / "notes.txt").write_text("")
    lib = motion_library(tmp_path)
    assert [n for n, _ in lib] == ["b", "sub/a"]
    assert lib[1][1] == tmp_path / "sub" / "a.npz"
    assert motion_library(tmp_path / "missing") == []


def test_bundled_sample_motions(body_model):
    names = dict(motion_library())
    assert {"idle_sway", "walk_in_place", "walk_forward"} <= set(names)
    walk = load_motion(names["walk_forward"])
    assert walk.rotvecs.shape[1:] == (104, 3)
    # Walks forwards (-Y) at a human pace with its feet on the floor.
    speed = -(walk.transl[-1, 1] - walk.transl[0, 1]) / walk.duration
    assert 0.6 < speed < 1.6
    feet = FootPointEvaluator(body_model)(walk.poses(np.arange(0, walk.num_frames, 10)))
    assert torch.all(feet[..., 2].min(dim=1).values.abs() < 0.006)


@pytest.mark.parametrize("make", [idle_sway, walk_cycle])
def test_procedural_motions_loop(body_model, make):
    rest = target_rest(body_model)
    rots, transl = make(rest, fps=30.0)
    T = transl.shape[0]
    for R in rots.values():
        R = np.asarray(R)
        # The frame after the last equals the first: step once more by the same amount.
        jump = np.abs(R[0] - R[-1]).max()
        typical = np.abs(np.diff(R, axis=0)).max()
        assert jump <= typical * 1.5 + 1e-9
    assert np.abs(transl[0] - transl[-1]).max() <= np.abs(np.diff(transl, axis=0)).max() * 1.5 + 1e-9
    assert T > 30
