"""Bad motion files through the commands a user runs (a subprocess each): exit code 2, one line
on stderr naming the file and what is wrong, no traceback, no numpy warning, nothing written."""

import io
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from motion_files import write_aist, write_amass_smplh
from motion_helpers import write_bvh

REPO = Path(__file__).resolve().parents[2]


def morf(*argv, cwd):
    env = dict(os.environ, MORF_QUIET="1", OMP_NUM_THREADS="1",
               PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("MORF_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "morf.cli.main", *map(str, argv)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)


def bvh_with(d: Path, frame_time=None, value=None) -> Path:
    path = d / "m.bvh"
    write_bvh(path, frames=4)
    lines = path.read_text().splitlines()
    i = lines.index("MOTION")
    if frame_time is not None:
        lines[i + 2] = f"Frame Time: {frame_time}"
    if value is not None:
        tok = lines[i + 5].split()  # frame 2
        tok[10] = value
        lines[i + 5] = " ".join(tok)
    path.write_text("\n".join(lines) + "\n")
    return path


def player_npz(d: Path, transl_value: float) -> Path:
    t = np.zeros((6, 3))
    t[2, 1] = transl_value
    np.savez(d / "m.npz", rotvecs=np.zeros((6, 104, 3)), transl=t, fps=30.0)
    return d / "m.npz"


def bomb(d: Path) -> Path:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 156)})
    with zipfile.ZipFile(d / "m.npz", "w") as z:
        z.writestr("poses.npy", buf.getvalue())
    return d / "m.npz"


def poked(path: Path, key: str, frame: int, value: float) -> Path:
    arrays = dict(np.load(path))
    arrays[key] = np.array(arrays[key], np.float64)
    arrays[key][frame, 0] = value
    np.savez(path, **arrays)
    return path


# name: (writer, what stderr must say after "m.<suffix>")
CASES = {
    "bvh nan": (lambda d: bvh_with(d, value="nan"), ": Yrotation of joint 'Spine' is NaN at frame 2; every rotation"),
    "bvh frame time 0": (lambda d: bvh_with(d, frame_time="0"), ": 'Frame Time: 0' is not a time between frames"),
    "npz 1e30 transl": (lambda d: player_npz(d, 1e30), ": 'transl' is 1e+30 m at frame 2; every translation"),
    "text npz": (lambda d: (d / "m.npz").write_text("rotvecs\n0 0 0\n") and d / "m.npz", " is not an .npz archive"),
    "npz bomb": (bomb, ": array 'poses' would take 1162.3 GiB in memory"),
    "amass nan": (lambda d: poked(write_amass_smplh(d / "m.npz", T=6), "poses", 3, np.nan),
                  ": 'poses' is NaN at frame 3"),
    "aist inf": (lambda d: poked(write_aist(d / "m.npz", T=6), "smpl_trans", 4, np.inf),
                 ": 'smpl_trans' divided by 'smpl_scaling' is inf at frame 4"),
}


def assert_refused(p, path: Path, says: str, folder: Path, before: set):
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2, p.stderr
    assert len(lines) == 1 and "Traceback" not in p.stderr and "Warning" not in p.stderr, p.stderr
    assert f"{path.name}{says}" in lines[0]
    assert "allow_pickle" not in lines[0]
    assert {f.name for f in folder.iterdir()} == before  # nothing written


@pytest.mark.parametrize("case", ["bvh nan", "npz 1e30 transl", "amass nan", "aist inf"])
def test_motion_export_refuses(tmp_path, case):
    """``morf motion export``: the reader every motion command shares, without an avatar."""
    write, says = CASES[case]
    path = write(tmp_path)
    before = {f.name for f in tmp_path.iterdir()}
    p = morf("motion", "export", path, "--out", "out.bvh", cwd=tmp_path)
    assert_refused(p, path, says, tmp_path, before)


@pytest.fixture(scope="module")
def avatar(tiny_avatar):
    """The session's tiny exported avatar: what is played does not matter here, only that the motion
    is refused (or played) before and around it."""
    return tiny_avatar


@pytest.mark.parametrize("case", ["bvh nan", "bvh frame time 0", "npz 1e30 transl", "text npz", "npz bomb"])
def test_play_refuses(tmp_path, avatar, case):
    write, says = CASES[case]
    path = write(tmp_path)
    before = {f.name for f in tmp_path.iterdir()}
    p = morf("play", avatar, "--motion", path, "--out", "out.mp4", "--size", 64, cwd=tmp_path)
    assert_refused(p, path, says, tmp_path, before)


def test_play_still_plays_a_good_bvh(tmp_path, avatar):
    path = bvh_with(tmp_path, frame_time="0.0333333")
    p = morf("play", avatar, "--motion", path, "--out", "frames", "--size", 64, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert len(list((tmp_path / "frames").glob("*.png"))) == 4
