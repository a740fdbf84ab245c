"""The output-path rule: new or empty outputs are used, anything else needs --force, and even then
only the command's own files are touched; projects are never written."""

from __future__ import annotations

import json

import pytest

from morf.errors import InputError
from morf.io.outputs import (RECORD, claim_output_file, claim_output_folder, read_record, staged_folder,
                             write_record)


def make_project(root):
    root.mkdir(parents=True)
    (root / "morf_project.json").write_text("{}")
    return root


def test_new_and_empty_folders_are_used(tmp_path):
    assert not claim_output_folder(tmp_path / "new", "morf x").existed
    (tmp_path / "empty").mkdir()
    claim = claim_output_folder(tmp_path / "empty", "morf x")
    assert claim.existed and not claim.foreign and not claim.previous


def test_foreign_files_need_force_and_are_reported(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / "keep.txt").write_text("mine")
    with pytest.raises(InputError, match=r"keep\.txt.*--force"):
        claim_output_folder(d, "morf x")
    claim = claim_output_folder(d, "morf x", force=True)
    assert claim.foreign == {"keep.txt"} and not claim.previous


def test_the_record_names_what_the_command_wrote(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / "a.png").write_bytes(b"1")
    write_record(d, "morf x", ["a.png"])
    assert read_record(d, "morf x") == {"a.png"} and read_record(d, "morf y") == frozenset()
    with pytest.raises(InputError, match="earlier output of morf x"):
        claim_output_folder(d, "morf x")  # its own earlier output: still --force outside its own place
    assert claim_output_folder(d, "morf x", force=True).previous == {"a.png"}
    assert claim_output_folder(d, "morf x", own_place=d).previous == {"a.png"}  # own place: re-run replaces
    # a record naming paths outside the folder is ignored
    (d / RECORD).write_text(json.dumps({"command": "morf x", "files": ["../../etc/passwd", "a.png", ".."]}))
    assert read_record(d, "morf x") == {"a.png"}


def test_projects_are_never_outputs(tmp_path):
    project = make_project(tmp_path / "P")
    (project / "frames").mkdir()
    for path in (project, project / "frames", project / "new"):
        with pytest.raises(InputError, match="capture project"):
            claim_output_folder(path, "morf x", force=True)
    claim = claim_output_folder(tmp_path, "morf x", force=True)  # the folder above it: its files are kept
    assert claim.foreign == {"P"}
    claim_output_folder(project / "avatar", "morf x", own_place=project / "avatar")  # its own place there
    with pytest.raises(InputError, match="inside the capture project"):
        claim_output_file(project / "walk.mp4", "morf x", force=True)
    assert not claim_output_file(tmp_path / "walk.mp4", "morf x").existed  # a file beside a project is fine


def test_files_devices_and_kinds(tmp_path):
    f = tmp_path / "v.mp4"
    f.write_bytes(b"old")
    with pytest.raises(InputError, match="already exists.*--force"):
        claim_output_file(f, "morf x")
    assert claim_output_file(f, "morf x", force=True).existed
    with pytest.raises(InputError, match="is a folder"):
        claim_output_file(tmp_path, "morf x", force=True)
    with pytest.raises(InputError, match="not a folder"):
        claim_output_folder(f, "morf x", force=True)
    with pytest.raises(InputError, match="not a regular file"):
        claim_output_file("/dev/null", "morf x", force=True)


def test_staged_folder_is_removed_on_failure_only(tmp_path):
    target = tmp_path / "out"
    with pytest.raises(RuntimeError):
        with staged_folder(target) as tmp:
            (tmp / "x").write_text("1")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with staged_folder(target) as tmp:
        (tmp / "x").write_text("1")
        tmp.rename(target)
    assert (target / "x").is_file() and oct(target.stat().st_mode & 0o777) != oct(0o700)
