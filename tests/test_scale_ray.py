"""Ray, in one file so that one local Ray of two workers serves every test that needs it (the
suite's workers take whole files; two files would each start a cluster, or wait on the other's):

- ``morf batch``: three tiny captures, one broken (reported, the others finish), a second run that
  continues from what is done; how captures are found;
- a training task whose worker is killed mid-training: Ray starts it again, the training resumes
  from its checkpoint and ends with the same avatar as a training nobody interrupted;
- tasks in this process without Ray (``--address here``), and Ray staying out of every command
  that does not use it."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from morf.cli.main import main
from morf.errors import InputError


@pytest.mark.slow
def test_batch_of_three_with_one_broken(tmp_path, capsys, tiny_capture_source, local_ray):
    caps = tmp_path / "captures"
    shutil.copytree(tiny_capture_source, caps / "alice")
    shutil.copytree(tiny_capture_source, caps / "bob")
    (caps / "broken").mkdir()
    (caps / "broken" / "morf_project.json").write_text("{not json")

    rc = main(["batch", str(caps), "--until", "train", "--preset", "tiny"])
    out = capsys.readouterr().out
    assert rc == 1, out
    data = json.loads((caps / "batch.json").read_text())
    rows = {r["name"]: r for r in data["captures"]}
    assert (data["done"], data["failed"], data["until"], data["preset"]) == (2, 1, "train", "tiny")
    assert data["ray"]["cpus"] == 2 and data["cpus_per_task"] == 1 and data["gpus_per_task"] == 0
    for name in ("alice", "bob"):
        assert rows[name]["status"] == "done" and rows[name]["exit_code"] == 0, rows[name]
        assert (caps / name / "runs" / "morf-tiny" / "avatar.pt").is_file()
        assert any(line.startswith("[3/3] train: done in") for line in rows[name]["log"])
    broken = rows["broken"]
    assert broken["status"] == "failed" and broken["exit_code"] == 2
    assert broken["error"].startswith("morf run: error: damaged project manifest")
    summary = out[out.index("capture  status"):].splitlines()
    assert [line.split()[:2] for line in summary[1:4]] == [["alice", "done"], ["bob", "done"], ["broken", "failed"]]
    assert "2 done, 1 failed" in out

    # the same captures from a list: finished stages are skipped, nothing runs again
    listing = tmp_path / "todo.txt"
    listing.write_text("# the two good ones\ncaptures/alice\n\n  captures/bob  \n")
    stamp = (caps / "alice" / "runs" / "morf-tiny" / "avatar.pt").stat().st_mtime_ns
    rc = main(["batch", str(listing), "--until", "train", "--preset", "tiny", "--workers", "1"])
    assert rc == 0, capsys.readouterr().out
    again = json.loads((tmp_path / "batch.json").read_text())
    assert [r["name"] for r in again["captures"]] == ["alice", "bob"]
    for r in again["captures"]:
        assert r["status"] == "done" and "[3/3] train: skipped (already done: run runs/morf-tiny)" in r["log"]
    assert (caps / "alice" / "runs" / "morf-tiny" / "avatar.pt").stat().st_mtime_ns == stamp


def test_a_gpu_batch_without_gpus_is_refused_in_one_line(tmp_path, capsys, local_ray):
    (tmp_path / "caps" / "one").mkdir(parents=True)
    rc = main(["batch", str(tmp_path / "caps"), "--preset", "gpu"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "1 GPUs, but no Ray node has them" in err[0], err


def test_a_task_that_raises_is_an_outcome_with_its_error(tmp_path, local_ray):
    import json

    from morf.capture.project import CaptureProject
    from morf.scale.tasks import Task, run_tasks

    seen = []
    outs = run_tasks([Task("parse", json.loads, ("[1, 2]",)), Task("bad json", json.loads, ("{",)),
                      Task("no project", CaptureProject.open, (str(tmp_path / "nowhere"),))],
                     workers=1, on_done=lambda o: seen.append(o.name))
    assert seen == ["parse", "bad json", "no project"]  # one at a time, in order
    assert outs[0].ok and outs[0].value == [1, 2] and outs[0].node
    assert outs[1].error.startswith("JSONDecodeError: Expecting property name")
    assert outs[2].error == f"project folder not found: {tmp_path / 'nowhere'}" and outs[2].value is None


def test_captures_of_a_folder_and_of_a_list(tmp_path):
    from morf.cli.batch import find_captures

    caps = tmp_path / "caps"
    for d in ("bob", "alice", ".hidden", "carol"):
        (caps / d).mkdir(parents=True)
    (caps / "carol.mp4").write_bytes(b"")  # carol/ is the project of this video
    (caps / "dave.MOV").write_bytes(b"")  # a video without its project yet
    (caps / "notes.txt").write_text("not a capture")
    found = find_captures(caps)
    assert [(c.name, c.project.name, c.video and c.video.name) for c in found] == [
        ("alice", "alice", None), ("bob", "bob", None), ("carol", "carol", "carol.mp4"), ("dave", "dave", "dave.MOV")]
    assert all(c.project.is_absolute() for c in found)

    (tmp_path / "other" / "alice").mkdir(parents=True)
    listing = tmp_path / "list.txt"
    listing.write_text("# comment\ncaps/alice\n\nother/alice\n  caps/dave.MOV\n")
    found = find_captures(listing)
    assert [c.name for c in found] == [str(caps / "alice"), str(tmp_path / "other" / "alice"), "dave"]
    assert found[2].project == caps / "dave" and found[2].video == caps / "dave.MOV"

    listing.write_text("caps/alice\ncaps/missing\n")
    with pytest.raises(InputError, match="do not exist: .*missing"):
        find_captures(listing)
    listing.write_text("caps/alice\ncaps/alice/\n")
    with pytest.raises(InputError, match="names .*alice twice"):
        find_captures(listing)
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no captures in the folder"):
        find_captures(tmp_path / "empty")
    with pytest.raises(InputError, match="captures not found"):
        find_captures(tmp_path / "nowhere")


def test_commands_that_do_not_run_on_ray_never_import_it():
    code = (
        "import sys\n"
        "from morf.cli.main import main\n"
        "for argv in (['--help'], ['batch', '--help'], ['bench', 'pareto', '--help'], ['run', '--help']):\n"
        "    try:\n"
        "        main(argv)\n"
        "    except SystemExit:\n"
        "        pass\n"
        "import morf.bench.pareto, morf.bench.stability, morf.cli.batch, morf.scale.tasks\n"
        "print('RAY' if 'ray' in sys.modules else 'NO RAY')\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "NO RAY"


def test_without_ray_the_error_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    from morf.scale.ray_runtime import require_ray

    monkeypatch.setitem(sys.modules, "ray", None)  # import ray now fails as if it were not installed
    with pytest.raises(InputError, match=r"pip install 'morf-studio\[ray\]'"):
        require_ray()
    (tmp_path / "caps" / "one").mkdir(parents=True)
    rc = main(["batch", str(tmp_path / "caps")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "morf-studio[ray]" in err[0], err


def test_tasks_in_process_need_no_ray(tmp_path, capsys, monkeypatch):
    import json

    from morf.capture.project import CaptureProject
    from morf.scale.ray_runtime import RayOptions
    from morf.scale.tasks import Resources, Task, run_tasks

    monkeypatch.setitem(sys.modules, "ray", None)  # as if the ray extra were not installed
    seen = []
    outs = run_tasks([Task("parse", json.loads, ("[1, 2]",), Resources(num_cpus=64)), Task("bad json", json.loads, ("{",)),
                      Task("no project", CaptureProject.open, (str(tmp_path / "nowhere"),))],
                     RayOptions(in_process=True), on_done=lambda o: seen.append(o.name))
    assert seen == ["parse", "bad json", "no project"]
    assert outs[0].ok and outs[0].value == [1, 2] and outs[0].node
    assert outs[1].error.startswith("JSONDecodeError: Expecting property name")
    assert outs[2].error == f"project folder not found: {tmp_path / 'nowhere'}" and outs[2].value is None

    # through the command: a broken capture is a failed row, reported, with no Ray anywhere
    (tmp_path / "caps" / "broken").mkdir(parents=True)
    (tmp_path / "caps" / "broken" / "morf_project.json").write_text("{not json")
    rc = main(["batch", str(tmp_path / "caps"), "--address", "here", "--until", "fit"])
    out = capsys.readouterr().out
    assert rc == 1 and "in this process, one after another" in out, out
    data = json.loads((tmp_path / "caps" / "batch.json").read_text())
    assert data["ray"]["address"] == "here" and data["failed"] == 1
    assert data["captures"][0]["error"].startswith("morf run: error: damaged project manifest")


def worker_pid(task_name: str) -> int | None:
    """The process running the Ray task ``task_name``: Ray titles it ``ray::<task name>``."""
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                cmd = (d / "cmdline").read_bytes().split(b"\0")[0].decode(errors="replace")
            except OSError:
                continue
            if cmd == f"ray::{task_name}":
                return int(d.name)
    return None


@pytest.mark.slow
def test_a_killed_training_resumes_from_its_checkpoint(tmp_path, tiny_capture_source, local_ray):
    import torch

    from morf.bench.pareto import Training, train_all
    from morf.train.config import preset
    from morf.train.run_dir import RunDir
    from morf.train.trained_avatar import load_trained_avatar
    from tests.conftest import copy_capture

    project = copy_capture(tiny_capture_source, tmp_path / "cap")
    # A checkpoint and a metrics line every step: the kill lands a quarter of the way, after step 6
    # has been checkpointed, and the resume has 18 steps left to match the straight run.
    cfg = preset("tiny", "morf", steps=24, checkpoint_minutes=0.0, log_every=1, inpaint_steps=2)
    killed_run = RunDir(project.runs_dir / "killed")
    kill: dict = {}

    def killer():
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:
            pid = worker_pid("cap/killed")
            logged = killed_run.read_metrics()
            if pid is not None and logged and logged[-1]["step"] >= 6:  # a quarter of the way, checkpointed
                os.kill(pid, signal.SIGKILL)
                kill.update(pid=pid, step=killed_run.load_checkpoint()["step"], done=killed_run.is_done)
                return
            time.sleep(0.02)

    thread = threading.Thread(target=killer, daemon=True)
    thread.start()
    root = str(project.root)
    trained = train_all([Training(root, cfg, "killed"), Training(root, cfg, "straight")], cpus_per_task=1)
    thread.join(timeout=5)

    assert kill and 5 <= kill["step"] < cfg.steps and not kill["done"], kill
    print(f"killed worker {kill['pid']} of task cap/killed after step {kill['step']} of {cfg.steps}")
    a, b = trained[(root, "killed")], trained[(root, "straight")]
    assert a.ok and b.ok, (a.error, b.error)
    assert f"resumed at step {kill['step']}" in killed_run.log_path.read_text()
    assert "resumed" not in RunDir(project.runs_dir / "straight").log_path.read_text()
    assert a.value.steps == b.value.steps == cfg.steps
    ta = load_trained_avatar(killed_run.root).texture
    tb = load_trained_avatar(project.runs_dir / "straight").texture
    assert torch.allclose(ta, tb, atol=1e-5)
    assert a.value.psnr_person == pytest.approx(b.value.psnr_person, abs=1e-4)
