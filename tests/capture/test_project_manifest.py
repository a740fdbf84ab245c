"""A project's own JSON files checked when read: the manifest's numbers and the review's frames."""

from __future__ import annotations

import json

import pytest

from morf.capture.project import CaptureProject
from morf.errors import ProjectError


@pytest.fixture()
def project(tmp_path):
    return CaptureProject.create(tmp_path / "P", num_frames=4, width=64, height=48, fps=30.0,
                                 source={"kind": "images", "path": str(tmp_path)})


@pytest.mark.parametrize("change, words", [
    ({"fps": -30.0}, "'fps' must be a frame rate"), ({"fps": float("nan")}, "'fps'"),
    ({"width": 10**9}, "'width' must be a whole number from 0 to 16384"), ({"num_frames": True}, "'num_frames'"),
    ({"frame_ext": "../x"}, "'frame_ext'"), ({"camera": {"fx": 0, "fy": 1, "cx": 1, "cy": 1, "width": 64, "height": 48}},
                                              "camera 'fx' must be a finite number above 0"),
    ({"camera": "front"}, "'camera' must be an object"),
])
def test_manifest_numbers_are_checked_on_open(project, change, words):
    path = project.root / "morf_project.json"
    d = json.loads(path.read_text())
    d.update(change)
    path.write_text(json.dumps(d))
    with pytest.raises(ProjectError, match=words.replace("(", r"\(")):
        CaptureProject.open(project.root)


@pytest.mark.parametrize("text", ['{"drop": [1e999]}', '{"drop": [4]}', '{"drop": [-1]}', '{"keep": "3"}',
                                  '{"drop": [true]}', '[1, 2]', "not json"])
def test_review_frames_must_be_frames_of_the_project(project, text):
    project.review_path().write_text(text)
    with pytest.raises(ProjectError, match="damaged review file"):
        project.load_review()


def test_review_round_trip(project):
    project.set_user_decision(3, "drop")
    project.set_user_decision(1, "keep")
    assert project.load_review() == {"drop": [3], "keep": [1]}


def test_unordered_views_flag_is_checked(project):
    path = project.root / "morf_project.json"
    d = json.loads(path.read_text())
    assert not CaptureProject.open(project.root).unordered_views
    d.update(unordered_views="yes")
    path.write_text(json.dumps(d))
    with pytest.raises(ProjectError, match="'unordered_views' must be true or false"):
        CaptureProject.open(project.root)
    d.update(unordered_views=True)  # with fps 30: a photo set cannot have a frame rate
    path.write_text(json.dumps(d))
    with pytest.raises(ProjectError, match="also gives a frame rate or frame times"):
        CaptureProject.open(project.root)
    d.update(fps=None)
    path.write_text(json.dumps(d))
    p = CaptureProject.open(project.root)
    assert p.unordered_views and p.frame_times() is None
