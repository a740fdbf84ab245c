"""``morf animate`` and ``morf play`` take every motion format a user brings, told by content;
anything else is one line naming what was found and what is expected."""

import cv2
import numpy as np
import pytest

from morf.cli.main import main
from motion_files import write_aist, write_amass_smplh, write_amass_smplx, write_capture_fits


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """A capture project with body fits (its shape drives retargeting in ``animate``)."""
    rng = np.random.default_rng(3)
    rot = (rng.normal(size=(8, 104, 3)) * 0.05).astype(np.float32)
    transl = np.zeros((8, 3), np.float32)
    transl[:, 0] = np.linspace(0.0, 0.3, 8)
    return write_capture_fits(tmp_path_factory.mktemp("capture") / "cap", rot, transl, fps=30.0)


def _frames(out):
    """Number of PNG frames in ``out``; the person must be on the first."""
    files = sorted(out.glob("*.png"))
    img = cv2.imread(str(files[0]))
    assert (img < 250).any(axis=-1).sum() > 50  # not just the white background
    return len(files)


# (file writer, extra options, frames rendered at 30 fps)
CASES = {
    "amass-smplh": (lambda d: write_amass_smplh(d / "walk_poses.npz", T=24, fps=120.0), [], 6),
    "amass-smplx": (lambda d: write_amass_smplx(d / "walk_stageii.npz", T=24, fps=60.0), [], 12),
    "aist++": (lambda d: write_aist(d / "gBR_sBM_cAll_d04_mBR0_ch01.npz", T=12), [], 6),  # 60 fps
    "aist++ stated rate": (lambda d: write_aist(d / "dance.npz", T=12), ["--motion-fps", "30"], 12),
}


@pytest.mark.parametrize("command", ["animate", "play"])
@pytest.mark.parametrize("case", list(CASES))
def test_smpl_family_files(tiny_avatar, capture, tmp_path, command, case):
    write, extra, frames = CASES[case]
    motion = write(tmp_path)
    target = [str(capture.root), "--avatar", str(tiny_avatar)] if command == "animate" else [str(tiny_avatar)]
    out = tmp_path / "frames"
    assert main([command, *target, "--motion", str(motion), "--out", str(out), "--size", "64", *extra]) == 0
    assert _frames(out) == frames


def test_another_captures_fits_drive_the_avatar(tiny_avatar, capture, tmp_path):
    out = tmp_path / "frames"
    assert main(["animate", str(capture.root), "--avatar", str(tiny_avatar), "--motion",
                 str(capture.fits_path), "--out", str(out), "--size", "64"]) == 0
    assert _frames(out) == 8


def test_cmu_bvh(tiny_avatar, capture, shared_data, tmp_path):
    out = tmp_path / "frames"
    assert main(["animate", str(capture.root), "--avatar", str(tiny_avatar), "--motion",
                 str(shared_data / "motion/cmu/131_01.bvh"), "--out", str(out), "--size", "64",
                 "--max-frames", "5"]) == 0
    assert _frames(out) == 5


@pytest.mark.parametrize("command", ["animate", "play"])
def test_wrong_npz_is_one_line(tiny_avatar, capture, tmp_path, capsys, command):
    np.savez(tmp_path / "weights.npz", conv1=np.zeros((8, 3, 3, 3)), fc=np.zeros(10))
    target = [str(capture.root), "--avatar", str(tiny_avatar)] if command == "animate" else [str(tiny_avatar)]
    rc = main([command, *target, "--motion", str(tmp_path / "weights.npz"), "--out", str(tmp_path / "v.mp4"),
               "--size", "64"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert "not a motion: found conv1 (8, 3, 3, 3), fc (10,)" in err[0]
    assert "expected" in err[0] and "AMASS" in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "v.mp4").exists()


def test_motion_fps_must_be_positive(tiny_avatar, tmp_path, capsys):
    motion = write_aist(tmp_path / "a.npz", T=4)
    assert main(["play", str(tiny_avatar), "--motion", str(motion), "--out", str(tmp_path / "f"),
                 "--motion-fps", "0"]) == 2
    err = capsys.readouterr().err
    assert "--motion-fps must be" in err and "positive" in err
