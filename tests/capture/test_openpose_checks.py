"""OpenPose numbers checked where they enter: finite, confidences in [0, 1], points within a few
frame sizes of the frame; one line naming the file, the key and the point. Through the reader and
through ``morf ingest`` as a user runs it."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from capture_helpers import body25, write_frames, write_masks, write_openpose
from morf.capture.openpose import check_pixel_coordinates, read_openpose_json
from morf.errors import InputError

REPO = Path(__file__).resolve().parents[2]


KEEP = object()


def person_file(path: Path, key: str = "pose_keypoints_2d", index: int = 0, value=KEEP, hands: bool = False) -> Path:
    """One person in a 64x48 frame; ``value`` replaces number ``index`` of ``key``."""
    person = {"pose_keypoints_2d": body25(10, 8, 30, 40)}
    if hands:
        person["hand_left_keypoints_2d"] = [20.0, 20.0, 0.5] * 21
        person["face_keypoints_2d"] = [20.0, 10.0, 0.7] * 70
    if value is not KEEP:
        person[key][index] = value  # None is JSON's null
    path.write_text(json.dumps({"people": [person]}))
    return path


@pytest.mark.parametrize("key,index,value,says", [
    ("pose_keypoints_2d", 5, 1.5, "pose_keypoints_2d point 1 has confidence 1.5; a confidence lies in [0, 1]"),
    ("pose_keypoints_2d", 2, -0.2, "pose_keypoints_2d point 0 has confidence -0.2; a confidence lies in [0, 1]"),
    ("pose_keypoints_2d", 24, 1e39, "pose_keypoints_2d point 8 has x 1e+39; coordinates are finite pixel positions"),
    ("pose_keypoints_2d", 25, 10**400, "pose_keypoints_2d holds values that are not numbers"),
    ("hand_left_keypoints_2d", 62, float("nan"), "hand_left_keypoints_2d point 20 has confidence nan; coordinates"),
    ("face_keypoints_2d", 0, None, "face_keypoints_2d point 0 has x nan; coordinates are finite pixel positions"),
])
def test_confidences_and_non_finite_values(tmp_path, key, index, value, says):
    p = person_file(tmp_path / "f_3.json", key, index, value, hands=True)
    with pytest.raises(InputError) as e:
        read_openpose_json(p)
    assert str(e.value).startswith(f"malformed OpenPose file {p}: {says}") and "\n" not in str(e.value)


def test_a_hair_over_one_is_rounding(tmp_path):
    p = person_file(tmp_path / "f.json", "pose_keypoints_2d", 5, 1.0000004)
    assert read_openpose_json(p)[0].pose[1, 2] == 1.0


@pytest.mark.parametrize("key,index,value,axis", [
    ("pose_keypoints_2d", 3, 1e30, "x = 1e+30"),  # point 1 (the neck): not in our layout, still checked
    ("pose_keypoints_2d", 1, -100.0, "y = -100"),  # 48 px high: more than two heights above
    ("pose_keypoints_2d", 0, 64 * 3 + 1.0, "x = 193"),
    ("face_keypoints_2d", 4, 1e6, "y = 1e+06"),
])
def test_points_far_outside_the_frame(tmp_path, key, index, value, axis):
    p = person_file(tmp_path / "f.json", key, index, value, hands=True)
    people = read_openpose_json(p)
    with pytest.raises(InputError) as e:
        check_pixel_coordinates(people, 64, 48, p)
    assert f"OpenPose file {p}: {key} point {index // 3} has {axis} px, more than 2 frame sizes outside the " \
           "64x48 frames" in str(e.value)


def test_points_a_little_outside_are_kept(tmp_path):
    p = person_file(tmp_path / "f.json", "pose_keypoints_2d", 0, -60.0)  # OpenPose guesses past the edge
    check_pixel_coordinates(read_openpose_json(p), 64, 48, p)


# ---- through morf ingest ---------------------------------------------------------------------------

def ingest(tmp_path, *argv):
    """``morf ingest P ARGV...`` in ``tmp_path``, as a user runs it."""
    env = dict(os.environ, MORF_QUIET="1", OMP_NUM_THREADS="1",
               PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("MORF_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "morf.cli.main", "ingest", "P", *map(str, argv)], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)


@pytest.fixture
def inputs(tmp_path):
    write_frames(tmp_path / "frames", 6)
    write_masks(tmp_path / "masks", 6, pattern="img_{i}_mask.png")
    return tmp_path


@pytest.mark.parametrize("change,says", [
    ((3, 3, 1e30), "img_3_keypoints.json: pose_keypoints_2d point 1 has x = 1e+30 px, more than 2 frame sizes"),
    ((2, 5, 7.0), "img_2_keypoints.json: pose_keypoints_2d point 1 has confidence 7; a confidence lies in [0, 1]"),
])
def test_ingest_refuses_bad_keypoints_in_one_line(inputs, change, says):
    kp = write_openpose(inputs / "kp", 6, [(10, 8, 30, 40)], pattern="img_{i}_keypoints.json")
    frame, index, value = change  # the file of frame ``frame``: number ``index`` of its body list
    f = kp / f"img_{frame}_keypoints.json"
    data = json.loads(f.read_text())
    data["people"][0]["pose_keypoints_2d"][index] = value
    f.write_text(json.dumps(data))
    p = ingest(inputs, "--frames", "frames", "--keypoints", "kp", "--masks", "masks")
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert says in lines[0]
    assert not (inputs / "P" / "keypoints.npz").exists()


def test_ingest_takes_good_keypoints(inputs):
    write_openpose(inputs / "kp", 6, [(10, 8, 30, 40)], pattern="img_{i}_keypoints.json")
    p = ingest(inputs, "--frames", "frames", "--keypoints", "kp", "--masks", "masks")
    assert p.returncode == 0, p.stderr
