"""``morf play`` on damaged avatar folders, as a user runs it: one line, exit 2, no traceback, and
nothing written. The checks themselves are in tests/export/test_avatar_folder.py."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from morf.io import save_npz


@pytest.fixture
def motion(tmp_path):
    path = tmp_path / "m.npz"
    save_npz(path, rotvecs=np.zeros((2, 104, 3), np.float32), transl=np.zeros((2, 3), np.float32), fps=np.array(30.0))
    return path


def play(avatar, motion, out) -> tuple[int, str]:
    r = subprocess.run([sys.executable, "-m", "morf.cli.main", "play", str(avatar), "--motion", str(motion),
                        "--out", str(out), "--size", "64"], capture_output=True, text=True, timeout=300)
    return r.returncode, r.stderr


def _flip_int8(root):
    data = bytearray((root / "renderer_int8.onnx").read_bytes())
    data[len(data) // 2] ^= 0x01
    (root / "renderer_int8.onnx").write_bytes(bytes(data))


def _manifest(change):
    def edit(root):
        m = json.loads((root / "manifest.json").read_text())
        change(m)
        (root / "manifest.json").write_text(json.dumps(m))
    return edit


CASES = {
    "bit-flipped int8 renderer": (_flip_int8, "avatar file renderer_int8.onnx in"),
    "no renderer section": (_manifest(lambda m: m.pop("renderer")), "no 'renderer' section"),
    "size multiple as text": (_manifest(lambda m: m["renderer"].__setitem__("size_multiple", "8")), "size_multiple"),
    "input layout a number": (_manifest(lambda m: m["renderer"].__setitem__("input_layout", 3)), "input_layout"),
    "file name out of the folder": (
        _manifest(lambda m: m["files"].__setitem__("../../etc/passwd", m["files"]["mesh.npz"])),
        "not the name of a file inside the avatar folder"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_damaged_avatar_is_one_line(tiny_avatar, motion, tmp_path, case):
    damage, words = CASES[case]
    avatar = tmp_path / "avatar"
    shutil.copytree(tiny_avatar, avatar)
    damage(avatar)
    rc, err = play(avatar, motion, tmp_path / "out.mp4")
    lines = [line for line in err.splitlines() if line.strip()]
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("morf play: error: "), err
    assert words in lines[0] and "export the avatar again" in lines[0], lines[0]
    assert "Traceback" not in err and not (tmp_path / "out.mp4").exists()
