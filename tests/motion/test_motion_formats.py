"""Every motion .npz kind is told by its content and read into the same Anny clip."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from morf.errors import InputError
from morf.motion import RetargetConfig, load_motion, save_clip
from morf.motion.formats import npz_motion_kind
from morf.motion.smpl import world_up
from morf.motion.so3 import rotvec_to_matrix
from motion_files import (Z_TO_Y_UP, smpl_body_motion, write_aist, write_amass_smplh, write_amass_smplx,
                          write_capture_fits)

RAW = RetargetConfig(fps=None, keep_feet_on_ground=False)


def _kind(path):
    from morf.io import load_npz

    return npz_motion_kind(load_npz(path, skip_pickled=True))


def test_kinds_are_told_by_content(tmp_path):
    assert _kind(write_amass_smplh(tmp_path / "a_poses.npz")) == "amass"
    assert _kind(write_amass_smplx(tmp_path / "b_stageii.npz")) == "amass"
    assert _kind(write_aist(tmp_path / "c.npz")) == "smpl"
    np.savez(tmp_path / "d.npz", poses=np.zeros((3, 72)), trans=np.zeros((3, 3)))
    assert _kind(tmp_path / "d.npz") == "smpl"
    np.savez(tmp_path / "e.npz", rotvecs=np.zeros((3, 104, 3)), transl=np.zeros((3, 3)), fps=np.array(24.0))
    assert _kind(tmp_path / "e.npz") == "player"
    rot = np.zeros((4, 104, 3), np.float32)
    project = write_capture_fits(tmp_path / "cap", rot, np.zeros((4, 3), np.float32))
    assert _kind(project.fits_path) == "fits"
    np.savez(tmp_path / "f.npz", weights=np.zeros(3))
    assert _kind(tmp_path / "f.npz") is None


def test_fits_are_told_by_the_keys_their_writer_declares(tmp_path):
    """morf.fitting.fits_io owns the fits format: the keys that mark a fits file are its own."""
    from morf.fitting.fits_io import FITS_ONLY_KEYS
    from morf.io import load_npz

    project = write_capture_fits(tmp_path / "cap", np.zeros((3, 104, 3), np.float32), np.zeros((3, 3), np.float32))
    arrays = load_npz(project.fits_path, skip_pickled=True)
    assert FITS_ONLY_KEYS and set(FITS_ONLY_KEYS) <= set(arrays)
    for key in FITS_ONLY_KEYS:  # any one of them is enough
        assert npz_motion_kind({"rotvecs": arrays["rotvecs"], "transl": arrays["transl"], key: arrays[key]}) == "fits"


def test_motion_kinds_and_the_fits_format_import_without_torch():
    """The torch-free player tells motion kinds by the fits format's own keys: neither module (nor
    the morf.fitting package they pass through) imports torch; the package's names still load."""
    script = textwrap.dedent("""
        import sys
        import morf.motion.formats, morf.fitting.fits_io
        assert "torch" not in sys.modules, "torch was imported"
        import morf.fitting
        assert morf.fitting.read_fits is morf.fitting.fits_io.read_fits and "torch" not in sys.modules
        assert not hasattr(morf.fitting, "no_such_name")
    """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]


def test_capture_fits_name_and_rate_come_from_the_project(tmp_path, body_model):
    """A fits file is named by the capture folder that holds it and takes that project's rate; a copy
    outside a project is named by its file and plays at the stated (or default) rate."""
    import shutil

    rot = np.zeros((4, 104, 3), np.float32)
    project = write_capture_fits(tmp_path / "cap", rot, np.zeros((4, 3), np.float32), fps=25.0)
    clip = load_motion(project.fits_path, body_model, config=RAW)
    assert clip.name == "cap" and clip.fps == 25.0
    shutil.copy(project.fits_path, tmp_path / "walk.npz")
    loose = load_motion(tmp_path / "walk.npz", body_model, config=RAW, source_fps=12.0)
    assert loose.name == "walk" and loose.fps == 12.0


def test_the_same_motion_in_every_smpl_layout_gives_the_same_clip(tmp_path, body_model):
    ref = load_motion(write_amass_smplh(tmp_path / "h.npz", fps=60.0), body_model, config=RAW)
    assert ref.fps == 60.0 and "smplh, male" in ref.source  # gender stored as bytes
    smplx = load_motion(write_amass_smplx(tmp_path / "x.npz", fps=60.0), body_model, config=RAW)
    assert "smplx, female" in smplx.source  # gender as text; the pickled marker dict is not loaded
    aist = load_motion(write_aist(tmp_path / "a.npz"), body_model, config=RAW)
    assert aist.fps == 60.0 and "aist++" in aist.source and "y-up" in aist.source  # AIST++'s own rate
    for clip in (smplx, aist):
        assert clip.num_frames == ref.num_frames
        np.testing.assert_allclose(clip.rotvecs, ref.rotvecs, atol=2e-5)
        np.testing.assert_allclose(clip.transl, ref.transl, atol=2e-5)


@pytest.mark.parametrize("world", ["z", "y", "-y"])
def test_plain_smpl_up_axis_is_found_from_the_data(tmp_path, body_model, world):
    body, trans = smpl_body_motion(12)
    ref = load_motion(write_amass_smplh(tmp_path / "h.npz", T=12, fps=30.0), body_model, config=RAW)
    from morf.motion.amass import SMPL_REST
    from morf.motion.so3 import matrix_to_rotvec

    W = {"z": np.eye(3), "y": Z_TO_Y_UP, "-y": np.diag([1.0, -1.0, -1.0]) @ Z_TO_Y_UP}[world]
    root = matrix_to_rotvec(W @ rotvec_to_matrix(body[:, :3]))
    pelvis = (trans + SMPL_REST[0]) @ W.T
    poses = np.concatenate([root, body[:, 3:], np.zeros((12, 6))], axis=1)
    np.savez(tmp_path / "s.npz", poses=poses, trans=pelvis - SMPL_REST[0], gender=np.array("neutral"))
    assert world_up(root) == (world[-1], -1 if world.startswith("-") else 1)
    clip = load_motion(tmp_path / "s.npz", body_model, config=RAW, source_fps=30.0)
    np.testing.assert_allclose(clip.rotvecs, ref.rotvecs, atol=2e-5)
    np.testing.assert_allclose(clip.transl, ref.transl, atol=2e-5)


def test_frame_rates(tmp_path, body_model):
    aist = write_aist(tmp_path / "a.npz", T=13)
    assert load_motion(aist, body_model, config=RAW).fps == 60.0  # AIST++ default
    assert load_motion(aist, body_model, config=RAW, source_fps=25.0).fps == 25.0  # stated
    smplh = write_amass_smplh(tmp_path / "h.npz", T=13, fps=120.0)
    assert load_motion(smplh, body_model, config=RAW, source_fps=25.0).fps == 120.0  # the file's own wins
    clip = load_motion(smplh, body_model)  # default output: 30 fps, feet on the ground
    assert clip.fps == 30.0 and clip.num_frames == 4
    with pytest.raises(InputError, match="frame rate given for the motion: frame rate is 0 fps; .* between"):
        load_motion(aist, body_model, source_fps=0.0)


def test_capture_fits_from_the_camera_world(tmp_path, body_model):
    from morf.motion import motion_library

    walk = load_motion(dict(motion_library())["walk_forward"])
    rot, transl = walk.rotvecs[:20], walk.transl[:20]
    cam = write_capture_fits(tmp_path / "cam", rot, transl, fps=25.0)
    up = write_capture_fits(tmp_path / "up", rot, transl, fps=25.0, camera_world=False)
    a = load_motion(cam.fits_path, body_model, config=RAW)
    b = load_motion(up.fits_path, body_model, config=RAW)
    assert a.fps == 25.0 and a.num_frames == 20 and a.name == "cam"  # the capture project's rate
    np.testing.assert_allclose(a.rotvecs, b.rotvecs, atol=1e-5)
    np.testing.assert_allclose(a.transl[:, :2], b.transl[:, :2], atol=1e-5)
    dz = a.transl[:, 2] - b.transl[:, 2]  # the camera's height is still in (the ground sets it below)
    assert np.ptp(dz) < 1e-5
    # Only the root turns: upright and facing -Y; every other bone keeps its fitted rotation.
    np.testing.assert_allclose(a.rotvecs[:, 1:], rot[:, 1:], atol=1e-6)
    R0 = rotvec_to_matrix(a.rotvecs[:, 0])
    assert np.median(R0[:, 2, 2]) > 0.99  # body up along +Z
    assert np.allclose(a.transl[0, :2], 0.0, atol=1e-6)
    # With the default config the feet land on the floor of the target body.
    from morf.motion.anny_rest import FootPointEvaluator

    grounded = load_motion(cam.fits_path, body_model)
    feet = FootPointEvaluator(body_model)(grounded.poses(np.arange(grounded.num_frames)))
    assert float(feet[..., 2].min(dim=1).values.abs().max()) < 0.01


def test_capture_fits_of_a_variable_frame_rate_clip_play_at_their_real_pace(tmp_path, body_model):
    from morf.motion import motion_library
    from morf.motion.clip import at_uniform_times

    # the sampler: frames at 0, 0.1, 0.3, 0.4 s sampled at 10 fps; 0.2 s lies halfway between 0.1 and 0.3
    rot = np.zeros((4, 2, 3))
    rot[:, 1, 2] = [0.0, 0.1, 0.3, 0.4]
    r, t = at_uniform_times(rot, rot[:, 1], np.array([0.0, 0.1, 0.3, 0.4]), 10.0)
    np.testing.assert_allclose(r[:, 1, 2], [0.0, 0.1, 0.2, 0.3, 0.4], atol=1e-6)
    np.testing.assert_allclose(t[:, 2], [0.0, 0.1, 0.2, 0.3, 0.4], atol=1e-9)
    # a capture whose manifest holds frame times (a phone clip with a slow stretch in the middle)
    walk = load_motion(dict(motion_library())["walk_forward"])
    cap = write_capture_fits(tmp_path / "vfr", walk.rotvecs[:20], walk.transl[:20], fps=25.0)
    times = np.arange(20) / 25.0
    times[10:] += 0.4  # ten frames missing after frame 9: 0.4 s without frames
    cap.manifest["frame_times"] = times.tolist()
    cap.save_manifest()
    clip = load_motion(cap.fits_path, body_model, config=RAW)
    assert clip.fps == 25.0 and clip.num_frames == 30  # 1.16 s at 25 fps
    even = load_motion(write_capture_fits(tmp_path / "cfr", walk.rotvecs[:20], walk.transl[:20], fps=25.0).fits_path,
                       body_model, config=RAW)
    assert even.num_frames == 20
    np.testing.assert_allclose(clip.rotvecs[20:], even.rotvecs[10:], atol=1e-5)  # the frames after the gap


def test_clip_and_player_npz_load_as_they_are(tmp_path):
    from morf.motion import MotionClip

    clip = MotionClip(np.zeros((4, 104, 3), np.float32), np.zeros((4, 3), np.float32), 24.0, "still", "test")
    save_clip(clip, tmp_path / "c.npz")
    assert load_motion(tmp_path / "c.npz").fps == 24.0
    np.savez(tmp_path / "p.npz", rotvecs=np.zeros((5, 104, 3)), transl=np.zeros((5, 3)))
    assert load_motion(tmp_path / "p.npz").fps == 30.0
    assert load_motion(tmp_path / "p.npz", source_fps=50.0).fps == 50.0


def test_unknown_npz_names_what_it_found(tmp_path):
    np.savez(tmp_path / "w.npz", weights=np.zeros((3, 4)), bias=np.zeros(4))
    with pytest.raises(InputError) as e:
        load_motion(tmp_path / "w.npz")
    msg = str(e.value)
    assert "\n" not in msg and "weights (3, 4)" in msg and "bias (4,)" in msg
    assert "AMASS" in msg and "AIST++" in msg and "fits" in msg
    np.savez(tmp_path / "p.npz", poses=np.zeros((4, 100)), trans=np.zeros((4, 3)))
    with pytest.raises(InputError, match=r"\(4, 100\)"):
        load_motion(tmp_path / "p.npz")
