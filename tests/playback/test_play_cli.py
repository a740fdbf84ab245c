"""``morf play``: a short motion to mp4 and to PNG frames; bad input is one line, exit 2."""

import cv2
import numpy as np

from morf.cli.main import main
from morf.io import save_npz


def _motion(path, frames=4):
    rng = np.random.default_rng(0)
    rot = (rng.normal(size=(frames, 104, 3)) * 0.1).astype(np.float32)
    rot[:, 0, 2] = np.linspace(0, 1, frames)
    save_npz(path, rotvecs=rot, transl=np.zeros((frames, 3), np.float32), fps=np.array(30.0))
    return path


def test_play_writes_video_and_frames(tiny_avatar, tmp_path):
    motion = _motion(tmp_path / "m.npz")
    assert main(["play", str(tiny_avatar), "--motion", str(motion), "--out", str(tmp_path / "v.mp4"), "--size", "64"]) == 0
    cap = cv2.VideoCapture(str(tmp_path / "v.mp4"))
    n = 0
    while cap.read()[0]:
        n += 1
    assert n == 4
    assert main(["play", str(tiny_avatar), "--motion", str(motion), "--out", str(tmp_path / "frames"),
                 "--size", "64", "--camera", "orbit", "--fps", "15"]) == 0
    assert len(list((tmp_path / "frames").glob("*.png"))) == 2
    # The motion is resampled by slerp at k / fps over its 0.1 s (first to last frame): 7 frames at 60 fps.
    assert main(["play", str(tiny_avatar), "--motion", str(motion), "--out", str(tmp_path / "frames60"),
                 "--size", "64", "--fps", "60"]) == 0
    assert len(list((tmp_path / "frames60").glob("*.png"))) == 7


def test_play_bad_motion(tiny_avatar, tmp_path, capsys):
    save_npz(tmp_path / "bad.npz", rotvecs=np.zeros((3, 5, 3), np.float32), transl=np.zeros((3, 3), np.float32))
    assert main(["play", str(tiny_avatar), "--motion", str(tmp_path / "bad.npz"), "--out", str(tmp_path / "v.mp4"),
                 "--size", "64"]) == 2
    assert "motion must be" in capsys.readouterr().err


def test_play_falls_back_to_fp32_when_int8_is_off_over_the_person(tiny_avatar, tmp_path, capsys):
    """The export's int8 check counts over the person too: a good whole-image PSNR with a bad one
    over the person (blotches on the body, the background exact) plays fp32 and says why."""
    import json
    import shutil

    avatar = tmp_path / "avatar"
    shutil.copytree(tiny_avatar, avatar)
    manifest = json.loads((avatar / "manifest.json").read_text())
    manifest["int8_quality"].update(psnr_db=36.0, psnr_person_db=26.2)
    (avatar / "manifest.json").write_text(json.dumps(manifest))
    motion = _motion(tmp_path / "m.npz", frames=2)
    assert main(["play", str(avatar), "--motion", str(motion), "--out", str(tmp_path / "f"), "--size", "64"]) == 0
    err = capsys.readouterr().err
    assert "only 26.2 dB from fp32 over the image or the person" in err and "playing fp32 instead" in err
    manifest["int8_quality"].update(psnr_db=36.0, psnr_person_db=34.0)
    (avatar / "manifest.json").write_text(json.dumps(manifest))
    assert main(["play", str(avatar), "--motion", str(motion), "--out", str(tmp_path / "g"), "--size", "64"]) == 0
    assert "playing fp32" not in capsys.readouterr().err
