"""Stages run one after another, each skipped when its output is complete and resumed when a
previous run stopped part-way: the chaining behind ``morf run`` and ``morf demo``.

A :class:`Step` is planned just before it runs (the step before may have changed what is on
disk), and every step is a ``morf`` sub-command, so a chained run does exactly what the user
would do by hand and prints what each command prints. One status line per step says whether it
was done, resumed or skipped.
"""

from __future__ import annotations

import shlex

import time
from dataclasses import dataclass
from typing import Callable, Sequence

ACTIONS = ("skip", "resume", "run")


@dataclass(frozen=True)
class Plan:
    """What a step does now.

    Fields:
        action: "skip" (its output is complete), "resume" (a stopped run is continued) or "run".
        argv: the ``morf`` sub-command and its arguments (empty for "skip").
        note: a few words for the status line ("12 frames from clip.mp4", "after stage 2 of 3").
    """

    action: str
    argv: tuple[str, ...] = ()
    note: str = ""

    def __post_init__(self):
        if self.action not in ACTIONS:
            raise ValueError(f"action must be one of {ACTIONS}, got {self.action!r}")
        if self.action != "skip" and not self.argv:
            raise ValueError(f"a step that does {self.action!r} needs a command")


@dataclass(frozen=True)
class Step:
    """One stage of a chain: its name and how to plan it from what is on disk at that moment."""

    name: str
    plan: Callable[[], Plan]


def run_steps(steps: Sequence[Step], command: Callable[[list[str]], int], who: str, again: str,
              log: Callable[[str], None] = print) -> int:
    """Plan and run ``steps`` in order; returns 0, or the exit status of the first that failed.

    Args:
        command: runs one ``morf`` sub-command (``morf.cli.main.main``) and returns its status.
        who: the chaining command's name for messages ("run", "demo").
        again: the command line that continues the chain ("morf run capture").
    """
    n = len(steps)
    for i, step in enumerate(steps, 1):
        head = f"[{i}/{n}] {step.name}"
        plan = step.plan()
        if plan.action == "skip":
            log(f"{head}: skipped (already done{': ' + plan.note if plan.note else ''})")
            continue
        why = f"resuming ({plan.note}): " if plan.action == "resume" and plan.note else (
            "resuming: " if plan.action == "resume" else "")
        log(f"{head}: {why}morf {shlex.join(plan.argv)}")
        t0 = time.perf_counter()
        rc = command(list(plan.argv))
        if rc == 130:
            log(f"morf {who}: stopped during {step.name}; to continue from there, run: {again}")
            return rc
        if rc != 0:
            log(f"morf {who}: {step.name} failed (exit {rc}); fix it and continue with: {again}")
            return rc
        done = "resumed and done" if plan.action == "resume" else "done"
        log(f"{head}: {done} in {time.perf_counter() - t0:.0f} s")
    return 0
