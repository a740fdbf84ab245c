"""The worker thread: commands reach a stage between steps, errors become snapshots, close stops it."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from morf.errors import MorfError
from morf.pipeline.control import Progress
from studio.commands import DropFrame, OpenProject, Pause, RestoreFrame, Resume, StartStage, Stop
from studio.worker import Worker


def wait_for(worker: Worker, predicate, timeout: float = 10.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        snap = worker.latest()
        if predicate(snap):
            return snap
        time.sleep(0.01)
    raise AssertionError(f"condition not reached; last snapshot: {worker.latest()}")


class CountingStage:
    """A fake stage: counts steps forever (or ``steps``), reporting a loss and a preview."""

    def __init__(self, steps: int | None = None):
        self.steps = steps
        self.done = 0
        self.stepping = threading.Event()

    def __call__(self, project, control, options):
        step = 0
        while self.steps is None or step < self.steps:
            control.check()
            step += 1
            self.done = step
            self.stepping.set()
            control.report(Progress("fake", step=step, total=self.steps, losses={"l1": 1.0 / step},
                                    images={"warp": np.full((4, 4, 3), step % 255, np.uint8)}))
            time.sleep(0.002)


def failing_stage(project, control, options):
    control.report(Progress("broken", step=1, total=3))
    raise RuntimeError("the stage broke")


def user_error_stage(project, control, options):
    raise MorfError("frames are missing")


@pytest.fixture
def worker_for(tiny_project):
    made = []

    def make(**stages):
        w = Worker(stages, unavailable={"train": "morf.train is not installed"}).start()
        w.send(OpenProject(str(tiny_project.root)))
        made.append(w)
        return w

    yield make
    for w in made:
        assert w.close(5.0)


def test_pause_resume_stop_reach_the_stage(worker_for):
    stage = CountingStage()
    w = worker_for(fake=stage)
    w.send(StartStage("fake"))
    wait_for(w, lambda s: s.progress is not None and s.progress.step >= 3)
    w.send(Pause())
    snap = wait_for(w, lambda s: s.state == "paused")
    held = stage.done
    time.sleep(0.3)
    assert stage.done <= held + 1  # at most the step that was already under way
    w.send(Resume())
    wait_for(w, lambda s: s.state == "running" and s.progress.step > held + 2)
    w.send(Stop())
    snap = wait_for(w, lambda s: s.state == "stopped")
    assert snap.stage == "fake" and snap.error is None
    curve = snap.curves["l1"]
    assert len(curve.steps) == len(curve.values) >= 3 and curve.values[0] == pytest.approx(1.0)
    assert snap.progress.images["warp"].shape == (4, 4, 3) and not snap.progress.images["warp"].flags.writeable
    assert snap.seconds_per_step is not None and snap.seconds_per_step > 0


def test_finished_stage_reports_eta_and_state(worker_for):
    w = worker_for(fake=CountingStage(steps=5))
    w.send(StartStage("fake"))
    snap = wait_for(w, lambda s: s.state == "finished")
    assert snap.progress.step == 5 and snap.progress.total == 5


def test_exceptions_become_error_snapshots_and_the_worker_lives_on(worker_for, capsys):
    w = worker_for(broken=failing_stage, user=user_error_stage, fake=CountingStage(steps=2))
    w.send(StartStage("broken"))
    snap = wait_for(w, lambda s: s.state == "failed")
    assert snap.error == "RuntimeError: the stage broke"
    w.send(StartStage("user"))
    snap = wait_for(w, lambda s: s.state == "failed" and s.stage == "user")
    assert snap.error == "frames are missing"
    w.send(StartStage("train"))
    snap = wait_for(w, lambda s: s.error and "not available" in s.error)
    assert "morf.train is not installed" in snap.error
    w.send(StartStage("fake"))  # still serving after three failures
    snap = wait_for(w, lambda s: s.state == "finished" and s.stage == "fake")
    assert snap.error is None and w.alive


def test_frame_decisions_are_written_by_the_worker_even_mid_stage(worker_for, tiny_project):
    w = worker_for(fake=CountingStage())
    w.send(StartStage("fake"))
    wait_for(w, lambda s: s.state == "running")
    w.send(DropFrame(2))
    snap = wait_for(w, lambda s: s.review_rev == 1)
    assert tiny_project.load_review()["drop"] == [2]
    assert snap.state == "running"
    w.send(RestoreFrame(2))
    wait_for(w, lambda s: s.review_rev == 2)
    assert tiny_project.load_review()["drop"] == []
    w.send(DropFrame(99))
    snap = wait_for(w, lambda s: s.error is not None)
    assert "out of range" in snap.error


def test_close_stops_a_running_stage(worker_for):
    stage = CountingStage()
    w = worker_for(fake=stage)
    w.send(StartStage("fake"))
    assert stage.stepping.wait(5.0)
    w.send(Pause())  # closing must also end a paused stage
    wait_for(w, lambda s: s.state == "paused")
    assert w.close(5.0)
    assert not w.alive
    assert w.latest().state in ("stopped", "stopping")


def test_opening_a_damaged_project_is_an_error_not_a_crash(tmp_path):
    (tmp_path / "morf_project.json").write_text("{ not json")
    w = Worker({}).start()
    try:
        w.send(OpenProject(str(tmp_path)))
        snap = wait_for(w, lambda s: s.error is not None)
        assert "damaged project manifest" in snap.error
    finally:
        assert w.close(5.0)


def test_a_pipeline_run_publishes_each_stage_and_opens_the_project_it_continues(tiny_project, monkeypatch):
    """RunPipeline as 'morf run PROJECT' plans it (ingest skipped: the project exists), each stage
    with its own name, step of the chain and progress; stopping in train, then running again,
    starts at train (fit is done by then, as the fake fit marks)."""
    from studio import pipeline_run
    from studio.commands import RunPipeline

    ran, stop_in_train = [], threading.Event()

    def fake(name):
        def stage(args, control):
            ran.append((name, args.project))
            control.report(Progress(name, step=1, total=2, losses={"l1": 0.5}))
            if name == "train" and stop_in_train.is_set():
                while True:
                    control.check()
                    time.sleep(0.01)
            if name == "fit":  # what a finished fit leaves: the plan skips it next time
                monkeypatch.setattr("morf.cli.project_steps.fit_plan",
                                    lambda root, preset: pipeline_run.Plan("skip", note="fits in fits/"))
        return stage

    for name in ("fit", "train", "export"):
        monkeypatch.setitem(pipeline_run.RUNNERS, name, fake(name))
    seen: list = []
    w = Worker({})
    w.mailbox = type(w.mailbox)(on_publish=lambda: seen.append(w.mailbox.latest()))
    w.start()
    try:
        stop_in_train.set()
        w.send(RunPipeline(pipeline_run.PipelineRequest(str(tiny_project.root))))
        wait_for(w, lambda s: s.stage == "train" and s.progress is not None)
        snap = w.latest()
        assert snap.chain_step == (3, 4) and snap.project == str(tiny_project.root) and snap.project_rev == 1
        assert [n for n, _ in ran] == ["fit", "train"]
        w.send(Stop())
        snap = wait_for(w, lambda s: not s.busy)
        assert snap.state == "stopped" and f"morf run {tiny_project.root}" in snap.message
        stop_in_train.clear()
        ran.clear()
        w.send(RunPipeline(pipeline_run.PipelineRequest(str(tiny_project.root))))
        snap = wait_for(w, lambda s: s.state == "finished" and s.stage == "export")
        assert [n for n, _ in ran] == ["train", "export"] and snap.chain_step == (4, 4)
        assert snap.project_rev == 1  # the open project is not opened again
        stages = [(s.stage, s.chain_step) for s in seen if s.chain_step is not None]
        assert ("fit", (2, 4)) in stages and ("export", (4, 4)) in stages
        assert max(s.stage_rev for s in seen) >= 4
    finally:
        w.close()
