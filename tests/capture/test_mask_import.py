"""Imported masks a user brings: unreadable, empty, damaged or wrongly sized files are one line
naming the file and what is needed, with nothing from OpenCV on stderr."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from capture_helpers import write_frames, write_masks, write_openpose
from morf.capture.mask_import import read_mask
from morf.errors import InputError
from test_openpose_checks import ingest


def good_mask(path: Path, w: int = 64, h: int = 48) -> Path:
    m = np.zeros((h, w), np.uint8)
    m[10:30, 20:40] = 255
    cv2.imwrite(str(path), m)
    return path


@pytest.mark.parametrize("make,says", [
    (lambda p: p.write_bytes(b""), "not a readable mask image: {p} (empty, damaged, or not an image format"),
    (lambda p: p.write_text("not an image"), "not a readable mask image: {p} (empty, damaged"),
    (lambda p: p.write_bytes(good_mask(p).read_bytes()[:40]), "not a readable mask image: {p}"),
    (lambda p: p.mkdir(), "cannot read mask {p}: Is a directory"),
    (lambda p: None, "cannot read mask {p}: No such file or directory"),
])
def test_unreadable_masks(tmp_path, capfd, make, says):
    p = tmp_path / "img_2_mask.png"
    make(p)
    with pytest.raises(InputError) as e:
        read_mask(p, 64, 48)
    assert str(e.value).startswith(says.format(p=p))
    assert capfd.readouterr().err == ""  # OpenCV's own warnings stay out of the user's terminal


def test_wrong_size_says_what_is_needed(tmp_path):
    p = good_mask(tmp_path / "m.png", 128, 96)
    with pytest.raises(InputError, match=r"mask m.png is 128x96 but the frames are 64x48; each mask must have its "
                                          r"frame's size \(before --resize\)"):
        read_mask(p, 64, 48)
    assert read_mask(good_mask(tmp_path / "ok.png"), 64, 48).sum() == 400


def test_sixteen_bit_and_colour_masks(tmp_path):
    m16 = np.zeros((48, 64), np.uint16)
    m16[10:30, 20:40] = 65535
    cv2.imwrite(str(tmp_path / "m16.png"), m16)
    assert read_mask(tmp_path / "m16.png", 64, 48).sum() == 400
    colour = np.zeros((48, 64, 3), np.uint8)
    colour[10:30, 20:40, 1] = 200
    cv2.imwrite(str(tmp_path / "c.png"), colour)
    assert read_mask(tmp_path / "c.png", 64, 48).sum() == 400


def test_ingest_with_a_damaged_mask_is_one_line(tmp_path):
    write_frames(tmp_path / "frames", 4)
    write_openpose(tmp_path / "kp", 4, [(10, 8, 30, 40)], pattern="img_{i}_keypoints.json")
    write_masks(tmp_path / "masks", 4, pattern="img_{i}_mask.png")
    (tmp_path / "masks" / "img_2_mask.png").write_text("not an image")
    p = ingest(tmp_path, "--frames", "frames", "--keypoints", "kp", "--masks", "masks")
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert "not a readable mask image: masks/img_2_mask.png" in lines[0]
