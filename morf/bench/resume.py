"""``morf bench resume --out DIR``: a ``kill -9`` at any moment of ``morf run``, then ``morf run``
again, must end with the avatar an uninterrupted run exports.

On a tiny synthetic capture (``morf synth --preset tiny``), ``morf run P --preset tiny`` runs once
uninterrupted: the reference avatar and the duration the kills are spread over. Then for each of
``--kills`` times (stratified: one uniform draw in each of K equal slices of that duration, seeded
by ``--seed``), a fresh copy of the capture gets ``morf run`` started in its own process group,
the whole group is sent SIGKILL at that time, and ``morf run`` runs again to the end. A time is
counted from the last status line (``[3/4] train: ...``) the reference had printed by then, in
the killed run's own output: on a shared machine one run's stages take longer than another's,
and a time on the reference's clock alone would land past the end of a faster run. The avatar
folder it exports is compared with the reference's:

* the same file list;
* every array of every .npz and every initializer of every .onnx graph equal within
  ``--tolerance`` (1e-5), the graphs' nodes the same operators in the same order;
* every JSON file (the manifest) with the same keys, apart from what records a time or a path
  (:mod:`morf.bench.avatar_diff`).

Per kill the table says when it came, which stage it hit (read from the killed run's own status
lines), what the second run did with that stage (resumed it, ran it again, or found it done) and
the largest difference. Writes ``DIR/resume.json`` and ``DIR/resume.md``.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from morf.bench.avatar_diff import AvatarDiff, compare_avatars

STAGES = ("ingest", "fit", "train", "export")
COLUMNS = ["kill", "at_s", "anchor", "stage_killed", "second_run", "passed", "max_abs_diff", "worst", "note"]


# ---- running, killing and reading ``morf run`` ---------------------------------------------

_STATUS = re.compile(r"^\[(\d+)/(\d+)\] (\w+): (.*)$")


def morf_argv(*args: str) -> list[str]:
    """A ``morf`` command line, as a user types it (:func:`morf.bench.common.morf_command`)."""
    from morf.bench.common import morf_command

    return [*morf_command(), *args]


def stage_lines(log: str) -> list[tuple[str, str]]:
    """(stage, rest of the line) of every ``[i/n] stage: ...`` status line ``morf run`` printed."""
    out = []
    for line in re.split(r"[\r\n]+", log):
        m = _STATUS.match(line.strip())
        if m and m.group(3) in STAGES:
            out.append((m.group(3), m.group(4)))
    return out


def stage_at_kill(log: str, finished: bool) -> str:
    """The stage a killed ``morf run`` was in, from its status lines: a stage name, "startup"
    (before the first status line), "after STAGE" (between two), or "finished" (it had ended)."""
    if finished:
        return "finished"
    lines = stage_lines(log)
    if not lines:
        return "startup"
    stage, rest = lines[-1]
    if rest.startswith("skipped") or " done in " in f" {rest}":
        return f"after {stage}"
    return stage


def stage_actions(log: str) -> dict[str, str]:
    """What a ``morf run`` did with each stage: "skipped", "ran", or "resumed" with the plan's note
    in parentheses ("resumed (after stage 2 of 3)", "resumed (from its checkpoint)")."""
    actions = {}
    for stage, rest in stage_lines(log):
        if stage in actions:
            continue
        if rest.startswith("skipped"):
            actions[stage] = "skipped"
        elif rest.startswith("resuming"):
            m = re.match(r"resuming \(([^)]*)\)", rest)
            actions[stage] = f"resumed ({m.group(1)})" if m else "resumed"
        else:
            actions[stage] = "ran"
    return actions


def second_run_word(stage_killed: str, actions: dict[str, str]) -> str:
    """What the run after the kill did with the stage that was killed (for a kill between two
    stages, with the next one it ran)."""
    stage = stage_killed.removeprefix("after ")
    if stage_killed.startswith("after ") and stage in STAGES:
        following = [s for s in STAGES[STAGES.index(stage) + 1:] if s in actions and actions[s] != "skipped"]
        if not following:
            return "nothing left to do"
        stage = following[0]
    if stage not in actions:
        return "nothing left to do" if stage_killed == "finished" else "-"
    action = actions[stage]
    word = "found it done" if action == "skipped" else "ran it again" if action == "ran" else \
        "resumed it" + action[len("resumed"):]
    return word if stage == stage_killed else f"{stage}: {word}"


def resumed_step(project: Path) -> int | None:
    """The step the last training session of ``project`` resumed at (its train.log), if any."""
    found = None
    for log in sorted(Path(project, "runs").glob("*/train.log")):
        for m in re.finditer(r"resumed at step (\d+)", log.read_text(errors="replace")):
            found = int(m.group(1))
    return found


def _environment() -> dict:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("MORF_DEBUG", None)
    return env


def run_to_end(argv: list[str], log_path: Path, timeout: float = 1800) -> tuple[int, float, list[float]]:
    """Run a command to its end with its output in ``log_path``; (exit status, seconds, the
    seconds after the start at which each of its status lines showed, polled every 20 ms)."""
    t0 = time.monotonic()
    marks: list[float] = []
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=_environment())
        while proc.poll() is None:
            if time.monotonic() - t0 > timeout:
                proc.kill()
                proc.wait()
                break
            now = time.monotonic() - t0
            marks += [now] * (len(stage_lines(log_path.read_text(errors="replace"))) - len(marks))
            time.sleep(0.02)
    seconds = time.monotonic() - t0
    marks += [seconds] * (len(stage_lines(log_path.read_text(errors="replace"))) - len(marks))
    return proc.returncode, seconds, marks


def run_and_kill(argv: list[str], at_s: float, log_path: Path,
                 after: Callable[[], bool] | None = None) -> tuple[bool, float]:
    """Start ``argv`` in a process group of its own and send the whole group SIGKILL ``at_s``
    seconds after the start, or, with ``after``, ``at_s`` seconds after ``after()`` first holds (a
    forced point, e.g. "the fit's checkpoint exists"; polled every 10 ms). Returns (whether it had
    ended by itself first, seconds it ran)."""
    t0 = time.monotonic()
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=_environment(),
                                start_new_session=True)
        while after is not None and not after() and proc.poll() is None:
            time.sleep(0.01)
        try:
            proc.wait(timeout=max(0.0, at_s))
            return True, time.monotonic() - t0
        except subprocess.TimeoutExpired:
            pass
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()
    return False, time.monotonic() - t0


def anchor(at_s: float, marks: list[float]) -> tuple[int, float]:
    """A time of the reference run as (status lines shown by then, seconds after the last of them):
    a killed run is killed that long after its own k-th status line, so each kill lands where the
    reference's time says even when this run's stages take longer or shorter (a shared machine)."""
    k = sum(1 for m in marks if m <= at_s)
    return k, at_s - (marks[k - 1] if k else 0.0)


def anchor_words(k: int, offset: float, reference_log: str) -> str:
    """``anchor``'s point in words: "start +0.8 s", "fit +1.2 s", "after fit +0.1 s"."""
    if k == 0:
        return f"start +{offset:.1f} s"
    stage, rest = stage_lines(reference_log)[k - 1]
    where = f"after {stage}" if rest.startswith("skipped") or " done in " in f" {rest}" else stage
    return f"{where} +{offset:.1f} s"


def kill_times(duration: float, kills: int, seed: int) -> list[float]:
    """``kills`` times in [0, duration): one uniform draw in each of ``kills`` equal slices."""
    rng = np.random.default_rng(seed)
    width = duration / kills
    return [round(float((i + rng.random()) * width), 3) for i in range(kills)]


# ---- the benchmark --------------------------------------------------------------------------

@dataclass(frozen=True)
class KillRow:
    """One kill: when (``at_s`` on the reference's clock; ``anchor``: the status line it was
    counted from in the killed run, :func:`anchor`), what it hit, what the next ``morf run`` did,
    and the avatar's difference from the reference's (``diff``, :class:`AvatarDiff`; None when no
    avatar came)."""

    kill: int
    at_s: float
    anchor: str
    stage_killed: str
    second_run: str
    actions: dict
    rc: int
    diff: AvatarDiff | None
    note: str = ""

    @property
    def passed(self) -> bool:
        return self.rc == 0 and self.diff is not None and self.diff.passed

    def to_dict(self) -> dict:
        d = asdict(self)
        d["diff"] = None if self.diff is None else self.diff.to_dict()
        d["passed"] = self.passed
        d["max_abs_diff"] = None if self.diff is None else self.diff.max_abs_diff
        d["worst"] = None if self.diff is None else self.diff.worst
        return d


def kill_once(capture: Path, work: Path, argv_for: Callable[[Path], list[str]], at_s: float, reference: Path,
              index: int, tolerance: float = 1e-5, output: str = "avatar",
              after: Callable[[Path], bool] | None = None, anchor_text: str = "") -> KillRow:
    """One kill of the benchmark in ``work`` (a fresh copy of ``capture`` there): ``argv_for(P)``
    (the ``morf run`` command line for project P) killed at ``at_s`` (:func:`run_and_kill`; with
    ``after``, after ``after(P)`` holds), run again to the end, and P/``output`` compared with
    ``reference``."""
    project = work / "P"
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    shutil.copytree(capture, project)
    ended, _ = run_and_kill(argv_for(project), at_s, work / "killed.log",
                            None if after is None else lambda: after(project))
    killed_log = (work / "killed.log").read_text(errors="replace")
    stage = stage_at_kill(killed_log, ended)
    rc, _, _ = run_to_end(argv_for(project), work / "again.log")
    again = (work / "again.log").read_text(errors="replace")
    actions = stage_actions(again)
    if actions.get("train") == "resumed (from its checkpoint)":
        step = resumed_step(project)
        actions["train"] = f"resumed (at step {step})" if step is not None else actions["train"]
    note = ""
    diff = None
    if rc != 0:
        note = _last_line(again)
    elif (project / output).is_dir():
        diff = compare_avatars(reference, project / output, tolerance)
        if not diff.passed:
            note = "; ".join([*(f"missing {m}" for m in diff.missing), *(f"extra {e}" for e in diff.extra),
                              *diff.key_diff][:3]) or f"differs at {diff.worst}"
    else:
        note = f"no {output} folder after the second run"
    return KillRow(index, at_s, anchor_text, stage, second_run_word(stage, actions), actions, rc, diff, note)


def _last_line(log: str) -> str:
    lines = [line.strip() for line in re.split(r"[\r\n]+", log) if line.strip()]
    return lines[-1][:200] if lines else ""


@dataclass(frozen=True)
class ResumeOptions:
    """What ``morf bench resume`` does.

    Fields:
        out: folder for resume.json / resume.md and the work files; kills: kills spread over the
        uninterrupted run's duration; seed: seed of the kill times; preset: the ``morf synth`` and
        ``morf run`` preset; tolerance: largest absolute difference allowed in any array; keep: keep
        every kill's project copy (else only failed ones).
    """

    out: str
    kills: int = 20
    seed: int = 0
    preset: str = "tiny"
    tolerance: float = 1e-5
    keep: bool = False


def _reference_run(opts: ResumeOptions, work: Path) -> tuple[Path, float, list[float]]:
    """Make the capture (``WORK/capture``) and run ``morf run`` on a copy of it to the end:
    (capture, duration in seconds, times of its status lines)."""
    from morf.errors import ProjectError

    capture = work / "capture"
    if capture.exists():
        shutil.rmtree(capture)
    capture.parent.mkdir(parents=True, exist_ok=True)
    rc, _, _ = run_to_end(morf_argv("synth", str(capture), "--preset", opts.preset), work / "synth.log")
    if rc != 0:
        raise ProjectError(f"morf synth failed (exit {rc}); see {work / 'synth.log'}")
    ref = work / "reference"
    if ref.exists():
        shutil.rmtree(ref)
    ref.mkdir()
    shutil.copytree(capture, ref / "P")
    rc, duration, marks = run_to_end(morf_argv("run", str(ref / "P"), "--preset", opts.preset), ref / "run.log")
    if rc != 0:
        raise ProjectError(f"the uninterrupted morf run failed (exit {rc}); see {ref / 'run.log'}")
    return capture, duration, marks


def _kill_rows(opts: ResumeOptions, work: Path, capture: Path, duration: float, marks: list[float]) -> list[KillRow]:
    """Every kill of :func:`kill_times`, each anchored to the reference's status lines."""
    reference = work / "reference" / "P" / "avatar"
    ref_log = (work / "reference" / "run.log").read_text(errors="replace")

    def argv_for(project: Path) -> list[str]:
        return morf_argv("run", str(project), "--preset", opts.preset)

    rows = []
    for i, at in enumerate(kill_times(duration, opts.kills, opts.seed)):
        kill_dir = work / f"kill-{i:02d}"
        k, offset = anchor(at, marks)
        after = None if k == 0 else (
            lambda project, k=k: len(stage_lines((project.parent / "killed.log").read_text(errors="replace"))) >= k)
        row = replace(kill_once(capture, kill_dir, argv_for, offset, reference, i, opts.tolerance, after=after,
                                anchor_text=anchor_words(k, offset, ref_log)), at_s=at)  # the reference's clock
        rows.append(row)
        print(f"kill {i:2d} at {at:6.2f} s in {row.stage_killed:<13} second run {row.second_run:<28} "
              f"{'pass' if row.passed else 'FAIL'} max diff {row.diff.max_abs_diff if row.diff else 'n/a'}", flush=True)
        if row.passed and not opts.keep:
            shutil.rmtree(kill_dir / "P", ignore_errors=True)
    return rows


def _markdown(opts: ResumeOptions, duration: float, rows: list[KillRow], cpu: str) -> str:
    from morf.bench.common import markdown_table

    passed = sum(r.passed for r in rows)
    table = [{**r.to_dict(), "passed": "pass" if r.passed else "FAIL",
              "max_abs_diff": "n/a" if r.diff is None else f"{r.diff.max_abs_diff:.3g}",
              "worst": (r.diff.worst if r.diff else "") or "-", "note": r.note or "-"} for r in rows]
    return (f"# morf bench resume\n\n`morf run P --preset {opts.preset}` on a `morf synth --preset {opts.preset}` "
            f"capture: uninterrupted in {duration:.1f} s; then {opts.kills} runs sent SIGKILL (the whole process "
            f"group) at a stratified random time of that run (seed {opts.seed}; counted from the status line the "
            f"anchor names, as the killed run printed it), each followed by `morf run` to the end, and the exported "
            f"avatar compared with the uninterrupted run's (same files, arrays within {opts.tolerance:g}). "
            f"**{passed} of {len(rows)} passed.**\n\nCPU: {cpu}\n\n"
            + markdown_table(table, COLUMNS))


def run_resume(opts: ResumeOptions) -> dict:
    """Kill ``morf run`` at ``opts.kills`` moments, run it again each time and compare the avatars;
    writes resume.json and resume.md; returns resume.json's content ("passed" of "rows")."""
    from morf.bench.common import machine_info, write_results
    from morf.errors import InputError

    if opts.kills < 1:
        raise InputError(f"--kills must be at least 1, got {opts.kills}")
    if not opts.tolerance >= 0:
        raise InputError(f"--tolerance must be >= 0, got {opts.tolerance}")
    out = Path(opts.out)
    work = out / "work"
    capture, duration, marks = _reference_run(opts, work)
    print(f"reference: morf run in {duration:.1f} s (status lines at "
          f"{', '.join(f'{m:.1f}' for m in marks)} s); {opts.kills} kills over it", flush=True)
    rows = _kill_rows(opts, work, capture, duration, marks)
    passed = sum(r.passed for r in rows)
    result = {"benchmark": "resume", "preset": opts.preset, "kills": opts.kills, "seed": opts.seed,
              "tolerance": opts.tolerance, "reference_seconds": round(duration, 2), "passed": passed,
              "rows": [r.to_dict() for r in rows], "machine": machine_info(),
              "command": f"morf bench resume --out {opts.out} --kills {opts.kills} --seed {opts.seed}"}
    path = write_results(out, "resume", result, _markdown(opts, duration, rows, result["machine"]["cpu"]))
    print(f"{passed} of {len(rows)} kills ended with the reference avatar; wrote {path}")
    return result
