"""SMPL / SMPL-X parameter files through the commands a user runs (``morf animate``, ``morf play``,
``morf motion export``) and the studio's motion loader: the AMASS fixture's motion in the split
layout renders the very same frames, and a bad file is one line."""

from pathlib import Path

import numpy as np
import pytest

from morf.cli.main import main
from motion_files import write_amass_smplh, write_amass_smplx, write_capture_fits
from smpl_param_files import hand_motion, write_single_fit, write_smpl_matrices, write_smpl_params, write_smplx_params


@pytest.fixture(scope="module")
def avatar(tiny_avatar):
    """The shared tiny exported avatar (tests/conftest.py): its mask follows the mesh coverage."""
    return tiny_avatar


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """A capture project with body fits: ``animate`` retargets onto its fitted shape."""
    rot = np.zeros((4, 104, 3), np.float32)
    return write_capture_fits(tmp_path_factory.mktemp("capture") / "cap", rot, np.zeros((4, 3), np.float32))


def _render(command, avatar, capture, motion, out, *extra):
    target = [str(capture.root), "--avatar", str(avatar)] if command == "animate" else [str(avatar)]
    assert main([command, *target, "--motion", str(motion), "--out", str(out), "--size", "64", *extra]) == 0
    return sorted(out.glob("*.png"))


def _same_frames(a: list[Path], b: list[Path]) -> None:
    assert len(a) == len(b) > 1
    for x, y in zip(a, b):
        assert x.read_bytes() == y.read_bytes(), f"{x.name} differs"


@pytest.mark.parametrize("command", ["animate", "play"])
def test_split_smpl_renders_the_amass_frames(avatar, capture, tmp_path, command):
    amass = _render(command, avatar, capture, write_amass_smplh(tmp_path / "walk_poses.npz", fps=120.0),
                    tmp_path / "amass")
    split = _render(command, avatar, capture, write_smpl_params(tmp_path / "walk.npz", dtype=np.float64),
                    tmp_path / "split", "--motion-fps", "120")
    _same_frames(amass, split)


def test_split_smplx_with_hands_renders_the_amass_smplx_frames(avatar, capture, tmp_path):
    from morf.io import load_npz

    hands = hand_motion(24)
    src = load_npz(write_amass_smplx(tmp_path / "h_stageii.npz"), skip_pickled=True)
    src["poses"][:, 75:] = hands
    np.savez(tmp_path / "h_stageii.npz", **src)
    amass = _render("animate", avatar, capture, tmp_path / "h_stageii.npz", tmp_path / "amass")
    split = _render("animate", avatar, capture,
                    write_smplx_params(tmp_path / "h.npz", dtype=np.float64, hands=hands, mocap_frame_rate=60.0),
                    tmp_path / "split")
    _same_frames(amass, split)
    plain = _render("animate", avatar, capture, write_smplx_params(tmp_path / "p.npz", dtype=np.float64,
                                                                   mocap_frame_rate=60.0), tmp_path / "plain")
    assert any(x.read_bytes() != y.read_bytes() for x, y in zip(split, plain)), "the fingers changed nothing"


@pytest.mark.parametrize("write,frames", [(write_smpl_params, 24), (write_smpl_matrices, 24), (write_single_fit, 1)])
def test_estimator_layouts_play(avatar, tmp_path, write, frames):
    assert len(_render("play", avatar, None, write(tmp_path / "m.npz"), tmp_path / "f")) == frames


def test_motion_export_and_the_studio_loader(tmp_path):
    from studio.player import load_live_motion

    motion = write_smplx_params(tmp_path / "x.npz", hands=hand_motion(24))
    assert main(["motion", "export", str(motion), "--out", str(tmp_path / "x.bvh")]) == 0
    assert (tmp_path / "x.bvh").read_text().startswith("HIERARCHY")
    clip, error = load_live_motion(motion, 104)
    assert error is None and clip.num_frames >= 24


@pytest.mark.parametrize("command", ["animate", "play", "motion"])
def test_a_bad_file_is_one_line(avatar, capture, tmp_path, capsys, command):
    np.savez(tmp_path / "bad.npz", global_orient=np.zeros((4, 3)), body_pose=np.full((4, 63), np.nan),
             transl=np.zeros((4, 3)))
    out = tmp_path / ("out.bvh" if command == "motion" else "out")
    args = {"animate": ["animate", str(capture.root), "--avatar", str(avatar)], "play": ["play", str(avatar)],
            "motion": ["motion", "export"]}[command]
    if command == "motion":
        args = [*args, str(tmp_path / "bad.npz"), "--out", str(out)]
    else:
        args = [*args, "--motion", str(tmp_path / "bad.npz"), "--out", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'body_pose' is NaN at frame 0" in err[0] and "Traceback" not in err[0], err
    assert not out.exists()
