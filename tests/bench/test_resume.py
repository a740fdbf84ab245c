"""``morf bench resume``: the avatar comparison, the reading of ``morf run``'s status lines, the
kill of a whole process group, and one real kill of ``morf run`` at a forced point."""

import json
import os
import shutil
import sys
import time

import numpy as np
import pytest

from morf.bench.avatar_diff import compare_avatars
from morf.bench.resume import (anchor, anchor_words, kill_once, kill_times, morf_argv, run_and_kill,
                               second_run_word, stage_actions, stage_at_kill)


def _avatar(folder, texture, weight=None, op="Add", manifest=None):
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    folder.mkdir(parents=True)
    np.savez(folder / "texture.npz", texture=texture, scales=np.ones(3, np.float32))
    w = numpy_helper.from_array(np.arange(4, dtype=np.float32) if weight is None else weight, "W")
    graph = helper.make_graph([helper.make_node(op, ["x", "W"], ["y"])], "g",
                              [helper.make_tensor_value_info("x", TensorProto.FLOAT, [4])],
                              [helper.make_tensor_value_info("y", TensorProto.FLOAT, [4])], [w])
    onnx.save(helper.make_model(graph), str(folder / "renderer.onnx"))
    base = {"format": "morf-avatar", "created": "2026-01-01 00:00:00", "export_seconds": 4.2,
            "source": {"project": "/a/P", "run": "morf-tiny"}, "int8_quality": {"psnr_db": 40.0},
            "files": {"texture.npz": {"bytes": 10, "sha256": "ab"}}}
    (folder / "manifest.json").write_text(json.dumps(manifest or base))
    (folder / "notes.txt").write_text("same")
    return base


def test_identical_avatars_pass_whatever_their_time_and_place(tmp_path):
    tex = np.random.default_rng(0).random((3, 8, 8)).astype(np.float32)
    base = _avatar(tmp_path / "a", tex)
    moved = {**base, "created": "2027-05-05 10:00:00", "export_seconds": 9.0,
             "source": {"project": "/elsewhere/P", "run": "morf-tiny"},
             "files": {"texture.npz": {"bytes": 11, "sha256": "cd"}}}
    _avatar(tmp_path / "b", tex + 5e-6, manifest=moved)
    d = compare_avatars(tmp_path / "a", tmp_path / "b")
    assert d.passed and 0 < d.max_abs_diff < 1e-5 and d.worst == "texture.npz:texture"
    assert d.key_diff == () and d.value_diff == ()


@pytest.mark.parametrize("change, worst", [
    ("texture", "texture.npz:texture"), ("weight", "renderer.onnx:init:W"), ("op", "renderer.onnx:graph:ops"),
])
def test_a_difference_beyond_the_tolerance_fails_and_is_located(tmp_path, change, worst):
    tex = np.zeros((3, 8, 8), np.float32)
    _avatar(tmp_path / "a", tex)
    if change == "texture":
        tex = tex.copy()
        tex[1, 2, 3] = 2e-5
    _avatar(tmp_path / "b", tex, weight=np.array([0, 1, 2, 3.001], np.float32) if change == "weight" else None,
            op="Mul" if change == "op" else "Add")
    d = compare_avatars(tmp_path / "a", tmp_path / "b")
    assert not d.passed and d.worst == worst and d.max_abs_diff > 1e-5


def test_missing_extra_files_and_manifest_keys_fail(tmp_path):
    tex = np.zeros((3, 8, 8), np.float32)
    base = _avatar(tmp_path / "a", tex)
    _avatar(tmp_path / "b", tex, manifest={**base, "new_key": 1, "int8_quality": {"psnr_db": 39.0}})
    (tmp_path / "b" / "notes.txt").unlink()
    (tmp_path / "b" / "extra.bin").write_bytes(b"x")
    d = compare_avatars(tmp_path / "a", tmp_path / "b")
    assert not d.passed
    assert d.missing == ("notes.txt",) and d.extra == ("extra.bin",)
    assert d.key_diff == ("manifest.json:new_key",)
    assert d.value_diff == ("int8_quality.psnr_db: 40.0 != 39.0",)  # reported, not failed on by itself
    (tmp_path / "b" / "notes.txt").write_text("changed")
    assert compare_avatars(tmp_path / "a", tmp_path / "b").worst == "notes.txt"


RUN_LOG = ("[1/4] ingest: skipped (already done: 12 frames)\n[2/4] fit: morf fit P --preset tiny\n"
           "fit 1/3 global:  40%|####\r\nfitted 12 frames\n[2/4] fit: done in 3 s\n"
           "[3/4] train: morf train P --preset tiny --name morf-tiny\n")


def test_status_lines_say_where_a_run_was_killed_and_what_the_next_one_did():
    assert stage_at_kill("", False) == "startup"
    assert stage_at_kill(RUN_LOG.split("fitted")[0], False) == "fit"
    assert stage_at_kill(RUN_LOG, False) == "train"
    assert stage_at_kill(RUN_LOG.rsplit("[3/4]", 1)[0], False) == "after fit"
    assert stage_at_kill(RUN_LOG, True) == "finished"
    again = ("[1/4] ingest: skipped (already done)\n[2/4] fit: resuming (after stage 2 of 3): morf fit P\n"
             "[2/4] fit: resumed and done in 2 s\n[3/4] train: morf train P\n[4/4] export: morf export P\n")
    actions = stage_actions(again)
    assert actions == {"ingest": "skipped", "fit": "resumed (after stage 2 of 3)", "train": "ran", "export": "ran"}
    assert second_run_word("fit", actions) == "resumed it (after stage 2 of 3)"
    assert second_run_word("train", actions) == "ran it again"
    assert second_run_word("after ingest", actions) == "fit: resumed it (after stage 2 of 3)"
    assert second_run_word("finished", {"fit": "skipped"}) == "nothing left to do"


def test_a_kill_time_is_counted_from_the_last_status_line_before_it():
    marks = [1.0, 1.1, 4.0, 9.0]  # ingest skipped, fit started, fit done, train started
    assert anchor(0.5, marks) == (0, 0.5)
    k, offset = anchor(6.5, marks)
    assert k == 3 and offset == pytest.approx(2.5)
    assert anchor_words(3, 2.5, RUN_LOG) == "after fit +2.5 s"
    assert anchor_words(2, 0.4, RUN_LOG) == "fit +0.4 s" and anchor_words(0, 0.5, RUN_LOG) == "start +0.5 s"


def test_kill_times_are_one_per_slice_and_seeded():
    t = kill_times(40.0, 20, seed=3)
    assert len(t) == 20 and all(2 * i <= x < 2 * (i + 1) for i, x in enumerate(t))
    assert t == kill_times(40.0, 20, seed=3) != kill_times(40.0, 20, seed=4)


CHILD_AND_WAIT = """
import subprocess, sys, time
child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
open(sys.argv[1], "w").write(str(child.pid))
print("[2/4] fit: morf fit P", flush=True)
time.sleep(60)
"""


def test_the_whole_process_group_is_killed(tmp_path):
    pid_file = tmp_path / "child.pid"
    ended, seconds = run_and_kill([sys.executable, "-c", CHILD_AND_WAIT, str(pid_file)], 0.0, tmp_path / "log",
                                  after=lambda: "[2/4] fit" in (tmp_path / "log").read_text())
    assert not ended and seconds < 30
    assert stage_at_kill((tmp_path / "log").read_text(), ended) == "fit"
    child = int(pid_file.read_text())
    for _ in range(200):  # the orphaned child is reaped by init once killed
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            break
        time.sleep(0.01)
    else:
        pytest.fail(f"the child {child} outlived the kill of its process group")


def test_morf_run_killed_after_the_fits_first_stage_ends_with_the_uninterrupted_fits(tmp_path, body_model):
    from tests.fitting.synthetic import write_project

    capture = write_project(tmp_path / "capture", body_model, n=6, bad=2).root

    def argv_for(project):
        return morf_argv("run", str(project), "--preset", "tiny", "--until", "fit")

    shutil.copytree(capture, tmp_path / "ref")
    ended, _ = run_and_kill(argv_for(tmp_path / "ref"), 600.0, tmp_path / "ref.log")
    assert ended, (tmp_path / "ref.log").read_text()[-2000:]
    row = kill_once(capture, tmp_path / "kill", argv_for, 0.0, tmp_path / "ref" / "fits", 0, output="fits",
                    after=lambda project: (project / "fits" / "checkpoint.npz").is_file())  # the first stage done
    assert row.stage_killed == "fit" and row.second_run.startswith("resumed it (after stage "), row
    assert row.passed and row.diff.max_abs_diff == 0.0, row
