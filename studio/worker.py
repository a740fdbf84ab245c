"""The worker thread: the only place that runs pipeline stages (and so owns models and optimisers).

The UI talks to it only through :meth:`Worker.send` (small command objects, ``studio.commands``)
and reads :meth:`Worker.latest` (frozen :class:`~studio.snapshot.Snapshot`). While a stage runs,
the worker drains its command queue whenever the stage reaches a safe point
(``StageControl.check`` / ``report``), so pause, stop and frame decisions take effect between steps
and review.json is only ever written by this thread.
"""

from __future__ import annotations

import dataclasses
import functools
import queue
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import Any, Callable

import numpy as np

from morf.capture.project import CaptureProject
from morf.errors import MorfError
from morf.pipeline.control import Progress, StageControl, StopRequested
from studio.commands import (Command, DropFrame, OpenProject, Pause, RestoreFrame, Resume, RunPipeline,
                             Shutdown, StartStage, Stop)
from studio.snapshot import LossCurve, Mailbox, Snapshot

# A stage as the worker calls it: (project, control, options) -> anything. Adapters for the
# library's stage functions live in studio/stages.py.
StageFn = Callable[[CaptureProject, StageControl, dict], Any]

MAX_CURVE_POINTS = 2000  # per loss; older points are thinned out, so publishing stays cheap


class _WorkerControl(StageControl):
    """A StageControl whose safe points also apply the UI's queued commands."""

    def __init__(self, worker: "Worker"):
        super().__init__(on_progress=worker._on_progress)
        self._worker = worker

    def check(self) -> None:
        if threading.current_thread() is self._worker._thread:
            stopped_before = self.stop_requested
            self._worker._drain(self)
            while self.paused and not self.stop_requested:
                self._worker._drain(self, timeout=0.1)
            if self.stop_requested and not stopped_before:
                # A stop learned just now is honoured at the next safe point: stages look at
                # ``stop_requested`` before ``check`` to write their checkpoint first
                # (morf.train does), and raising here would skip that.
                return
        super().check()

    def report(self, progress: Progress) -> None:
        if threading.current_thread() is self._worker._thread:
            self._worker._drain(self)
        super().report(progress)


class _Curve:
    def __init__(self):
        self.steps: list[float] = []
        self.values: list[float] = []

    def add(self, step: float, value: float) -> None:
        self.steps.append(step)
        self.values.append(value)
        if len(self.steps) >= 2 * MAX_CURVE_POINTS:
            self.steps, self.values = self.steps[::2], self.values[::2]

    def frozen(self) -> LossCurve:
        s, v = np.asarray(self.steps, np.float64), np.asarray(self.values, np.float64)
        s.flags.writeable = v.flags.writeable = False
        return LossCurve(s, v)


def _readonly_copy(img: np.ndarray) -> np.ndarray:
    a = np.array(img, copy=True)
    a.flags.writeable = False
    return a


class Worker:
    """Runs stages on a background thread. Create, :meth:`start`, :meth:`send`, :meth:`close`.

    Args:
        stages: stage name -> function; see :data:`StageFn`.
        unavailable: stage name -> why it cannot run (shown when the UI asks for it anyway).
        stage_threads: torch threads for stages (None: leave torch's setting). The app leaves one
            core to the UI: on a 2-core machine torch's spinning threads otherwise starve it.
        on_publish: called on the worker thread after each new snapshot (the UI's wake-up).
    """

    def __init__(self, stages: dict[str, StageFn], unavailable: dict[str, str] | None = None,
                 stage_threads: int | None = None, on_publish: Callable[[], None] | None = None):
        self._stages = dict(stages)
        self._stage_threads = stage_threads
        self._unavailable = dict(unavailable or {})
        self._commands: "queue.Queue[Command]" = queue.Queue()
        self.mailbox = Mailbox(on_publish=on_publish)
        self._thread = threading.Thread(target=self._main, name="morf-worker", daemon=True)
        self._project: CaptureProject | None = None
        self._control: _WorkerControl | None = None
        self._shutdown = False
        self._snap = Snapshot()
        self._curves: dict[str, _Curve] = {}
        self._run_start = 0.0
        self._paused_since: float | None = None
        self._paused_total = 0.0
        self._last_report: tuple[float, int] | None = None
        self._sent = 0  # commands sent (UI thread) ...
        self._done = 0  # ... and applied (worker thread); plain ints: one writer each

    # ---- UI side ------------------------------------------------------------------------
    def start(self) -> "Worker":
        self._thread.start()
        return self

    @property
    def native_id(self) -> int | None:
        """The worker thread's OS id (for per-thread CPU accounting), once started."""
        return self._thread.native_id

    def send(self, command: Command) -> None:
        self._sent += 1
        self._commands.put(command)

    def pending(self) -> int:
        """Commands sent but not yet applied (a running StartStage counts until the stage ends)."""
        return self._sent - self._done

    def latest(self) -> Snapshot:
        return self.mailbox.latest()

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def close(self, timeout: float = 10.0) -> bool:
        """Stop any running stage, end the thread; True when it ended within ``timeout``."""
        if not self._thread.is_alive():
            return True
        self.send(Shutdown())
        self._thread.join(timeout)
        return not self._thread.is_alive()

    # ---- worker thread ------------------------------------------------------------------
    def _main(self) -> None:
        while not self._shutdown:
            command = self._commands.get()
            if isinstance(command, StartStage):
                self._run_stage(command)
            elif isinstance(command, RunPipeline):
                self._run_pipeline(command)
            else:
                self._apply(command, None)
            self._done += 1

    def _drain(self, control: _WorkerControl, timeout: float | None = None) -> None:
        """Apply queued commands (waiting up to ``timeout`` for the first one)."""
        try:
            command = self._commands.get(timeout=timeout) if timeout else self._commands.get_nowait()
        except queue.Empty:
            return
        while True:
            self._apply(command, control)
            self._done += 1
            try:
                command = self._commands.get_nowait()
            except queue.Empty:
                return

    def _apply(self, command: Command, control: _WorkerControl | None) -> None:
        try:
            if isinstance(command, Shutdown):
                self._shutdown = True
                if control is not None:
                    control.stop()
                    self._publish(state="stopping", message="closing: stopping the stage")
            elif isinstance(command, (Pause, Resume, Stop)):
                self._control_command(command, control)
            elif isinstance(command, (DropFrame, RestoreFrame)):
                self._review(command)
            elif isinstance(command, OpenProject):
                if control is not None:  # finish (stop) the stage first, then open
                    control.stop()
                    self._commands.put(command)
                    self._done -= 1  # applied later, counted then
                    return
                self._open(command.root)
            elif isinstance(command, (StartStage, RunPipeline)):
                what = command.stage if isinstance(command, StartStage) else "a pipeline run"
                self._publish(message=f"'{self._snap.stage}' is still running; stop it before starting {what}")
        except MorfError as e:
            self._publish(error=str(e), message="")
        except Exception as e:  # a broken command must not end the worker
            traceback.print_exc(file=sys.stderr)
            self._publish(error=f"{type(e).__name__}: {e}", message="")

    def _control_command(self, command: Command, control: _WorkerControl | None) -> None:
        if control is None:
            self._publish(message="no stage is running")
            return
        now = time.monotonic()
        if isinstance(command, Pause) and not control.paused:
            control.pause()
            self._paused_since = now
            self._publish(state="paused", message=f"{self._snap.stage} paused")
        elif isinstance(command, Resume) and control.paused:
            control.resume()
            self._paused_total += now - (self._paused_since or now)
            self._paused_since = None
            self._last_report = None  # the pause is not a slow step
            self._publish(state="running", message=f"{self._snap.stage} resumed")
        elif isinstance(command, Stop):
            control.stop()
            self._publish(state="stopping", message=f"stopping {self._snap.stage} at the next safe point")

    def _review(self, command: DropFrame | RestoreFrame) -> None:
        if self._project is None:
            self._publish(error="no project is open")
            return
        if isinstance(command, DropFrame):
            decision, word = "drop", "dropped"
        elif command.index in self._project.load_review()["drop"]:
            decision, word = None, "restored"  # back to the automatic filter's verdict
        else:
            decision, word = "keep", "kept (overrides the filter)"
        try:
            self._project.set_user_decision(command.index, decision)
        except IndexError as e:
            raise MorfError(str(e)) from None
        self._publish(review_rev=self._snap.review_rev + 1, message=f"frame {command.index} {word}", error=None)

    def _open(self, root: str | None) -> None:
        self._project = None if root is None else CaptureProject.open(root)
        self._publish(project=root, state="idle", stage=None, chain_step=None, progress=None, curves={}, error=None,
                      message="" if root is None else f"opened {Path(root).name}")

    def _run_stage(self, command: StartStage) -> None:
        name = command.stage
        fn = self._stages.get(name)
        if fn is None:
            why = self._unavailable.get(name, "unknown stage")
            self._publish(error=f"stage '{name}' is not available: {why}")
            return
        if self._project is None:
            self._publish(error=f"open a project before running '{name}'")
            return
        control = self._begin(name)
        project = self._project
        self._finish(name, control, lambda: fn(project, control, dict(command.options)))

    def _run_pipeline(self, command: RunPipeline) -> None:
        """ingest -> fit -> train -> export as ``morf run`` chains them (studio.pipeline_run); each
        stage publishes as its own (name, progress, curves, clock), and the project is opened as
        soon as ingest made it, so the UI shows the frames while the body is fitted."""
        from morf.pipeline.chain import Step, run_steps
        from studio.pipeline_run import plan_steps, stage_runner

        request = command.request
        control = self._begin("ingest", chain_step=None)

        def run() -> None:
            steps = plan_steps(request)  # checks the folder and the video first: a bad start fails at once
            n = len(steps)
            planned = [Step(s.name, functools.partial(self._next_step, request.root, s, i, n))
                       for i, s in enumerate(steps, 1)]
            rc = run_steps(planned, stage_runner(control), "studio", request.again_command(), log=self._log)
            self._open_made(request.root)
            self._publish(stage_rev=self._snap.stage_rev + 1)
            if rc not in (0, 130):
                raise MorfError(f"stopped with exit status {rc}")

        self._finish(self._snap.stage or "ingest", control, run, again=request.again_command())

    def _next_step(self, root: str, step, index: int, total: int):
        """Plan step ``index`` of ``total`` of a pipeline run, and publish it as the running stage."""
        if index > 1:  # the step before ended: its files are on disk, and the project exists
            self._open_made(root)
            self._publish(stage_rev=self._snap.stage_rev + 1)
        self._curves, self._run_start, self._paused_total, self._last_report = {}, time.monotonic(), 0.0, None
        self._publish(stage=step.name, chain_step=(index, total), progress=None, curves={}, elapsed_s=0.0,
                      seconds_per_step=None, eta_s=None, message=f"{step.name} ({index} of {total})")
        return step.plan()

    def _open_made(self, root: str) -> None:
        """Open the project a pipeline run made, unless it is open already."""
        if not CaptureProject.is_project(Path(root)):
            return
        if self._project is not None and self._project.root.resolve() == Path(root).resolve():
            return
        self._project = CaptureProject.open(root)
        self._publish(project=str(root), project_rev=self._snap.project_rev + 1)

    def _log(self, line: str) -> None:
        """A pipeline run's status line ('[2/4] fit: skipped ...'): printed as ``morf run`` prints it."""
        print(line, flush=True)
        self._publish(message=line)

    def _begin(self, name: str, **changes) -> _WorkerControl:
        if self._stage_threads:
            import torch  # the stages use it anyway; imported here, not at app start

            torch.set_num_threads(self._stage_threads)
        control = _WorkerControl(self)
        self._control, self._curves = control, {}
        self._run_start, self._paused_total, self._paused_since, self._last_report = time.monotonic(), 0.0, None, None
        self._publish(state="running", stage=name, progress=None, curves={}, error=None, elapsed_s=0.0,
                      seconds_per_step=None, eta_s=None, message=f"{name} started", **{"chain_step": None, **changes})
        return control

    def _finish(self, name: str, control: _WorkerControl, body: Callable[[], Any], again: str | None = None) -> None:
        """Run ``body`` (a stage) and publish how it ended; errors are shown, never raised."""
        state, error = "finished", None
        try:
            body()
            if control.stop_requested:
                state = "stopped"
        except StopRequested:
            state = "stopped"
        except MorfError as e:
            state, error = "failed", str(e)
        except Exception as e:  # shown in the status line; the app keeps running
            traceback.print_exc(file=sys.stderr)
            state, error = "failed", f"{type(e).__name__}: {e}"
        finally:
            self._control = None
        name = self._snap.stage or name
        message = f"{name} {state}"
        if again and state in ("stopped", "failed"):
            message += f"; Make avatar (Training panel) continues from here, as does: {again}"
        self._publish(state=state, error=error, elapsed_s=self._elapsed(), eta_s=None, message=message)

    def _elapsed(self) -> float:
        paused = self._paused_total + (time.monotonic() - self._paused_since if self._paused_since else 0.0)
        return time.monotonic() - self._run_start - paused

    def _on_progress(self, p: Progress) -> None:
        """Runs on the stage's thread: fold the report into the next snapshot."""
        for name, value in p.losses.items():
            self._curves.setdefault(name, _Curve()).add(float(p.step), float(value))
        now = time.monotonic()
        sps = self._snap.seconds_per_step
        if self._last_report is not None and p.step > self._last_report[1]:
            dt = (now - self._last_report[0]) / (p.step - self._last_report[1])
            sps = dt if sps is None else 0.8 * sps + 0.2 * dt  # smoothed: steps vary
        self._last_report = (now, p.step)
        eta = sps * max(p.total - p.step, 0) if (sps is not None and p.total) else None
        progress = dataclasses.replace(p, images={k: _readonly_copy(v) for k, v in p.images.items()},
                                       losses=dict(p.losses))
        self._publish(progress=progress, curves={k: c.frozen() for k, c in self._curves.items()},
                      elapsed_s=self._elapsed(), seconds_per_step=sps, eta_s=eta)

    def _publish(self, **changes) -> None:
        self._snap = dataclasses.replace(self._snap, seq=self._snap.seq + 1, **changes)
        self.mailbox.publish(self._snap)
