"""A training task whose worker is killed mid-training: Ray starts it again, the training resumes
from its checkpoint and ends with the same avatar as a training nobody interrupted."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest


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
