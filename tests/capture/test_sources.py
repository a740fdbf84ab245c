"""Frame sources, side-file matching, OpenPose parsing and mask reading (no detector)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from morf.capture.mask_import import read_mask, resize_mask
from morf.capture.matching import match_files
from morf.capture.openpose import HandsFace, check_pixel_coordinates, read_openpose_json
from morf.capture.video import natural_key, open_images, open_video
from morf.errors import InputError
from capture_helpers import body25, write_frames, write_video


def test_video_streams_every_kth_frame(tmp_path):
    src = open_video(write_video(tmp_path / "v.avi", 7))
    assert (src.kind, src.width, src.height, src.fps, src.frame_count) == ("video", 64, 48, 10.0, 7)
    frames = list(src.frames(every=3))
    assert [f.index for f in frames] == [0, 3, 6]
    assert frames[1].rgb.shape == (48, 64, 3) and frames[1].rgb.dtype == np.uint8
    assert [f.index for f in src.frames(every=2, max_frames=2)] == [0, 2]
    assert src.kept_indices(every=3) == [0, 3, 6]
    assert not src.warnings


def test_image_folder_natural_order_and_size_check(tmp_path):
    folder = write_frames(tmp_path / "f", 12)
    (folder / "notes.txt").write_text("ignored")
    src = open_images(folder)
    assert src.kind == "images" and src.frame_count == 12
    assert src.names[:3] == ("img_0", "img_1", "img_2") and src.names[-1] == "img_11"
    assert [f.name for f in src.frames(every=5)] == ["img_0", "img_5", "img_10"]
    cv2.imwrite(str(folder / "img_12.png"), np.zeros((40, 40, 3), np.uint8))
    with pytest.raises(InputError, match="differ in size"):
        list(open_images(folder).frames())
    assert natural_key("f2") < natural_key("f10")


def test_single_image_and_wrong_kinds(tmp_path):
    folder = write_frames(tmp_path / "f", 1)
    src = open_images(folder / "img_0.png")
    assert src.kind == "image" and src.frame_count == 1
    with pytest.raises(InputError, match="use --video"):
        open_images(write_video(tmp_path / "v.avi", 2))
    with pytest.raises(InputError, match="not a video file"):
        open_video(folder)


def test_matching_by_name_number_and_order(tmp_path):
    files = [tmp_path / n for n in ("a_keypoints.json", "b_keypoints.json")]
    m = match_files(files, [0, 1], ("b", "a"), 2, "OpenPose")
    assert m.rule == "name" and m.get(0).name == "b_keypoints.json"
    files = [tmp_path / f"clip_{i:012d}_keypoints.json" for i in range(0, 20, 2)]
    m = match_files(files, [0, 4, 8], None, None, "OpenPose")
    assert m.rule == "number" and m.get(4).name == "clip_000000000004_keypoints.json"
    files = [tmp_path / f"mask{c}.png" for c in "abc"]
    m = match_files(files, [0, 2], None, 3, "mask")
    assert m.rule == "order" and m.get(2).name == "maskc.png"
    with pytest.raises(InputError, match="4 frames but 3 mask files: one mask file is needed for each frame"):
        match_files(files, [0, 2], None, 4, "mask")
    with pytest.raises(InputError, match="no mask file for frame 5"):
        match_files(files, [0, 5], None, None, "mask")


def _write(path: Path, obj) -> Path:
    path.write_text(json.dumps(obj) if not isinstance(obj, str) else obj)
    return path


def test_openpose_body25_coco18_hands_face(tmp_path):
    body = body25(10, 10, 50, 90)
    p = _write(tmp_path / "a.json", {"people": [
        {"pose_keypoints_2d": body, "hand_left_keypoints_2d": [7.0, 8.0, 0.5] * 21, "face_keypoints_2d": []},
        {"pose_keypoints_2d": []},  # OpenPose writes empty lists for undetected parts
        {"pose_keypoints_2d": [float(v) if v % 3 != 2 else 0.5 for v in range(54)]},
    ]})
    people = read_openpose_json(p)
    assert [q.layout for q in people] == ["BODY_25", "COCO-18"]
    first = people[0]
    # BODY_25 point 11 is the right ankle, our 16; OpenPose integer pixel centres -> +0.5
    assert first.body[16].tolist() == pytest.approx([body[33] + 0.5, body[34] + 0.5, body[35]])
    assert first.body[:, 2].min() > 0  # BODY_25 has every point of our layout (feet included)
    assert first.hand_left.shape == (21, 3) and first.hand_right is None and first.face is None
    coco = people[1]
    assert (coco.body[17:, 2] == 0).all()  # COCO-18 has no feet
    hf = HandsFace.stack([first, None], scale=2.0)
    assert hf.present.tolist() == [True, False]
    assert hf.hand_left[0, 0].tolist() == pytest.approx([15.0, 17.0, 0.5])


@pytest.mark.parametrize("text, word", [
    ('{"people": [', "malformed"),
    ('[1, 2]', "no 'people' list"),
    ('{"people": [{"pose_keypoints_2d": [1, 2, 3, 4]}]}', "expected 75"),
    ('{"people": [{"pose_keypoints_2d": ' + json.dumps(["x"] * 75) + '}]}', "not numbers"),
    ('{"people": [{"pose_keypoints_2d": ' + json.dumps([1.0] * 75) + ', "face_keypoints_2d": [1, 2]}]}', "face_keypoints_2d"),
])
def test_openpose_malformed_files_name_the_file(tmp_path, text, word):
    p = _write(tmp_path / "frame_7.json", text)
    with pytest.raises(InputError, match=word) as e:
        read_openpose_json(p)
    assert "frame_7.json" in str(e.value)


def test_openpose_normalised_coordinates_are_refused(tmp_path):
    p = _write(tmp_path / "n.json", {"people": [{"pose_keypoints_2d": body25(0.1, 0.1, 0.6, 0.9)}]})
    # the +0.5 shift still leaves every coordinate under 1.5: clearly not pixels of a 640 px frame
    with pytest.raises(InputError, match="normalised"):
        check_pixel_coordinates(read_openpose_json(p), 640, 480, p)


def test_mask_reading(tmp_path):
    m = np.zeros((48, 64), np.uint8)
    m[10:30, 20:40] = 255
    cv2.imwrite(str(tmp_path / "m.png"), m)
    got = read_mask(tmp_path / "m.png", 64, 48)
    assert got.dtype == bool and got.sum() == 400
    rgba = np.zeros((48, 64, 4), np.uint8)
    rgba[..., :3] = 255  # colour says nothing; the alpha cut-out is the mask
    rgba[10:30, 20:40, 3] = 255
    cv2.imwrite(str(tmp_path / "cut.png"), rgba)
    assert (read_mask(tmp_path / "cut.png", 64, 48) == got).all()
    with pytest.raises(InputError, match="64x48 but the frames are 32x24"):
        read_mask(tmp_path / "m.png", 32, 24)
    small = resize_mask(got, 32, 24)
    assert small.shape == (24, 32) and small.sum() == 100


def test_exif_focal_length(tmp_path):
    from PIL import Image

    from morf.capture.video import exif_focal_px

    img = Image.fromarray(np.zeros((300, 400, 3), np.uint8))
    exif = Image.Exif()
    exif.get_ifd(0x8769)[0xA405] = 35  # FocalLengthIn35mmFilm
    img.save(tmp_path / "e.jpg", exif=exif)
    img.save(tmp_path / "plain.jpg")
    assert exif_focal_px(tmp_path / "e.jpg", 400, 300) == pytest.approx(35 * 500 / 43.27)
    assert exif_focal_px(tmp_path / "plain.jpg", 400, 300) is None
