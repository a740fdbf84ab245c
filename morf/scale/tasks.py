"""A list of calls run as Ray tasks, each on the resources it declares, with one outcome per call
(or, with ``RayOptions(in_process=True)``, one after another in this process, without Ray).

A :class:`Task` names a module-level function and its arguments; workers import the function by
its module and name (so it must be importable there: ``morf`` installed on every node), and the
arguments travel pickled between our own processes (paths and configs, never loaded projects).
A task whose worker dies (killed, out of memory, node lost) is started again up to ``retries``
times; the functions run here pick up where the dead one stopped (a training resumes from its
checkpoint, ``morf run`` skips finished stages). An exception the function raises is its
outcome's error, not retried: the other tasks go on.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

from morf.errors import MorfError
from morf.scale.ray_runtime import RayOptions, Resources, check_fits, connect


@dataclass(frozen=True)
class Task:
    """One call to run on a Ray worker.

    Fields:
        name: unique; Ray's task name and the worker's process title while it runs (``ray::NAME``).
        fn: a module-level function; args: its positional arguments (picklable, small).
        resources: what it holds while it runs.
        retries: new starts after its worker died (an exception raised by ``fn`` is not retried).
    """

    name: str
    fn: Callable
    args: tuple = ()
    resources: Resources = field(default_factory=Resources)
    retries: int = 2


@dataclass(frozen=True)
class Outcome:
    """How one task ended.

    Fields:
        name: the task's name; value: what ``fn`` returned (None when it failed);
        error: one line saying why it failed, None when it did not; seconds: from start to end;
        node: where it ran last, "HOST:NODE" (the first 8 hex digits of Ray's node id; None when
            it failed).
    """

    name: str
    value: Any = None
    error: str | None = None
    seconds: float = 0.0
    node: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


class TasksFailed(MorfError):
    """Some tasks failed; the message lists each with its error (the others' results are kept)."""

    exit_code = 1

    def __init__(self, what: str, failed: Sequence[Outcome]):
        self.failed = tuple(failed)
        super().__init__(f"{len(failed)} {what} failed: " + "; ".join(f"{o.name}: {o.error}" for o in failed))


def run_tasks(tasks: Sequence[Task], options: RayOptions | None = None, workers: int | None = None,
              on_done: Callable[[Outcome], None] | None = None) -> list[Outcome]:
    """Run ``tasks`` on Ray, at most ``workers`` at once (None: as many as the resources allow),
    started in the order given; returns their outcomes in that order. ``on_done`` is called here,
    in the calling process, with each outcome as it arrives. Ctrl-C cancels the running tasks."""
    names = [t.name for t in tasks]
    if len(set(names)) != len(names):
        raise ValueError(f"task names must be unique: {names}")
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if not tasks:
        return []
    if options is not None and options.in_process:
        return _run_here(tasks, on_done)
    ray = connect(options)
    for res in {t.resources for t in tasks}:
        check_fits(res, options)
    remote = ray.remote(_call)
    outcomes: list[Outcome | None] = [None] * len(tasks)
    waiting = list(range(len(tasks)))
    running: dict = {}  # ObjectRef -> (task index, start time)
    try:
        while waiting or running:
            while waiting and (workers is None or len(running) < workers):
                i = waiting.pop(0)
                t = tasks[i]
                ref = remote.options(name=t.name, num_cpus=t.resources.num_cpus, num_gpus=t.resources.num_gpus,
                                     max_retries=t.retries, retry_exceptions=False).remote(
                    t.fn, t.args, max(1, int(t.resources.num_cpus)))
                running[ref] = (i, time.perf_counter())
            ready, _ = ray.wait(list(running), num_returns=1)
            for ref in ready:
                i, t0 = running.pop(ref)
                try:
                    value, node = ray.get(ref)
                    out = Outcome(tasks[i].name, value=value, seconds=time.perf_counter() - t0, node=node)
                except Exception as e:  # noqa: BLE001 -- every failure of a task is its outcome
                    out = Outcome(tasks[i].name, error=_why(e, tasks[i].retries), seconds=time.perf_counter() - t0)
                outcomes[i] = out
                if on_done is not None:
                    on_done(out)
    except BaseException:
        for ref in running:
            try:
                ray.cancel(ref, force=True)
            except Exception:  # noqa: BLE001 -- it may have ended meanwhile
                pass
        raise
    return outcomes  # type: ignore[return-value]


def threads_here(resources: Resources) -> int:
    """Torch threads a task gets in this process: its CPUs, but no more than the process runs."""
    import torch

    return max(1, min(torch.get_num_threads(), int(resources.num_cpus)))


def _error_line(e: BaseException) -> str:
    """One line for an exception a task's function raised: a MorfError's own message, else its
    type and the first line of its text."""
    if isinstance(e, MorfError):
        return str(e)
    return f"{type(e).__name__}: {e}".splitlines()[0]


def _run_here(tasks: Sequence[Task], on_done: Callable[[Outcome], None] | None) -> list[Outcome]:
    """The tasks one after another in this process (no Ray), each on its CPUs' worth of torch
    threads but no more than this process runs already; an exception the function raises is its
    outcome's error, as on Ray."""
    import socket

    import torch

    outcomes = []
    threads = torch.get_num_threads()
    for t in tasks:
        t0 = time.perf_counter()
        torch.set_num_threads(threads_here(t.resources))
        try:
            out = Outcome(t.name, value=t.fn(*t.args), seconds=time.perf_counter() - t0, node=socket.gethostname())
        except Exception as e:  # noqa: BLE001 -- every failure of a task is its outcome
            out = Outcome(t.name, error=_error_line(e), seconds=time.perf_counter() - t0)
        finally:
            torch.set_num_threads(threads)
        outcomes.append(out)
        if on_done is not None:
            on_done(out)
    return outcomes


def _call(fn: Callable, args: tuple, threads: int) -> tuple[Any, str]:
    """Runs on the worker: torch on the task's CPUs, then the call; (its value, "HOST:NODE")."""
    import socket

    import ray
    import torch

    torch.set_num_threads(threads)
    value = fn(*args)
    return value, f"{socket.gethostname()}:{ray.get_runtime_context().get_node_id()[:8]}"


def _why(e: Exception, retries: int) -> str:
    """One line for a failed task: the function's own error, or how its worker died."""
    import ray.exceptions as rx

    if isinstance(e, rx.RayTaskError):
        cause = getattr(e, "cause", None)
        if cause is not None:
            return _error_line(cause)
    if isinstance(e, (rx.WorkerCrashedError, rx.NodeDiedError, rx.OutOfMemoryError)):
        return (f"its worker died {retries + 1} times (killed, out of memory, or its node was lost): "
                f"{type(e).__name__}")
    if isinstance(e, rx.TaskCancelledError):
        return "cancelled"
    lines = [line for line in str(e).splitlines() if line.strip()]
    return f"{type(e).__name__}: {lines[0] if lines else ''}"


_WORKER_CACHE: dict[str, Any] = {}


def worker_cached(key: str, make: Callable[[], Any]) -> Any:
    """``make()``, made once per worker process and kept for the tasks it runs next (Ray reuses
    workers): e.g. the body model every training task needs."""
    if key not in _WORKER_CACHE:
        _WORKER_CACHE[key] = make()
    return _WORKER_CACHE[key]
