"""``morf bench resume --out DIR``: a ``kill -9`` at any moment of ``morf run``, then ``morf run``
again, must end with the avatar an uninterrupted run exports.

On a tiny synthetic capture (``morf synth --preset tiny``), ``morf run P --preset tiny`` runs once
uninterrupted: the reference avatar and the duration the kills are spread over. Then for each of
``--kills`` times (stratified: one uniform draw in each of K equal slices of that duration, seeded
by ``--seed``), a fresh copy of the capture gets ``morf run`` started in its own process group,
the whole group is sent SIGKILL at that time, and ``morf run`` runs again to the end. The avatar
folder it exports is compared with the reference's:

* the same file list;
* every array of every .npz equal within ``--tolerance`` (1e-5), every initializer of every .onnx
  graph the same, their nodes the same operators in the same order;
* every JSON file (the manifest) with the same keys, apart from what records a time or a path.

Per kill the table says when it came, which stage it hit (read from the killed run's own status
lines), what the second run did with that stage (resumed it, ran it again, or found it done) and
the largest difference. Writes ``DIR/resume.json`` and ``DIR/resume.md``.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np

STAGES = ("ingest", "fit", "train", "export")
COLUMNS = ["kill", "at_s", "stage_killed", "second_run", "passed", "max_abs_diff", "worst", "note"]
# manifest keys that record when, how long or where, not what was exported
VOLATILE_KEYS = frozenset({"created", "export_seconds", "project", "sha256", "bytes", "seconds", "written", "finished"})


# ---- comparing two avatar folders ---------------------------------------------------------

@dataclass(frozen=True)
class AvatarDiff:
    """How an avatar folder differs from a reference one (:func:`compare_avatars`).

    Fields:
        missing, extra: files the reference has and this folder lacks, and the other way round;
        max_abs_diff: the largest absolute difference of any array or initializer (inf when two
            cannot be compared: another shape, dtype kind, or a name only one of them has);
        worst: "file:array" where it is; key_diff: JSON keys only one side has ("file:a.b.c");
        value_diff: JSON values (not times or paths) that differ, for information; tolerance:
            what ``max_abs_diff`` had to stay within.
    """

    missing: tuple[str, ...]
    extra: tuple[str, ...]
    max_abs_diff: float
    worst: str
    key_diff: tuple[str, ...]
    value_diff: tuple[str, ...]
    tolerance: float

    @property
    def passed(self) -> bool:
        return not self.missing and not self.extra and not self.key_diff and self.max_abs_diff <= self.tolerance

    def to_dict(self) -> dict:
        return {**asdict(self), "passed": self.passed}


def _files(folder: Path) -> set[str]:
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}


def _array_diff(a: np.ndarray, b: np.ndarray) -> float:
    """Largest absolute difference of two arrays; inf when they cannot be compared."""
    if a.shape != b.shape:
        return float("inf")
    if a.dtype.kind in "US" or b.dtype.kind in "US":
        return 0.0 if a.dtype.kind == b.dtype.kind and np.array_equal(a, b) else float("inf")
    if a.dtype.kind not in "biuf" or b.dtype.kind not in "biuf":
        return 0.0 if np.array_equal(a, b) else float("inf")
    if a.size == 0:
        return 0.0
    d = np.abs(a.astype(np.float64) - b.astype(np.float64))
    nan_a, nan_b = np.isnan(a.astype(np.float64)), np.isnan(b.astype(np.float64))
    if (nan_a != nan_b).any():
        return float("inf")
    return float(np.nanmax(np.where(nan_a, 0.0, d)))


def npz_arrays(path: Path) -> dict[str, np.ndarray]:
    from morf.io import load_npz

    return load_npz(path)


def onnx_arrays(path: Path) -> dict[str, np.ndarray]:
    """The graph's initializers by name, plus its operator sequence as one string array (so two
    graphs with other nodes but the same weights do not pass)."""
    import onnx
    from onnx import numpy_helper

    model = onnx.load(str(path))
    out = {f"init:{t.name}": numpy_helper.to_array(t) for t in model.graph.initializer}
    out["graph:ops"] = np.array(" ".join(n.op_type for n in model.graph.node))
    return out


def _json_diff(a, b, where: str, keys: list[str], values: list[str], tol: float) -> None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b), key=str):
            here = f"{where}.{k}" if where else str(k)
            if k in VOLATILE_KEYS:
                if (k in a) != (k in b):
                    keys.append(here)
                continue
            if k not in a or k not in b:
                keys.append(here)
            else:
                _json_diff(a[k], b[k], here, keys, values, tol)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            _json_diff(x, y, f"{where}[{i}]", keys, values, tol)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if not abs(float(a) - float(b)) <= tol * max(1.0, abs(float(a))):
            values.append(f"{where}: {a} != {b}")
    elif a != b:
        values.append(f"{where}: {a!r} != {b!r}")


def compare_avatars(reference: str | Path, other: str | Path, tolerance: float = 1e-5) -> AvatarDiff:
    """Compare avatar folder ``other`` with ``reference`` (see the module docstring for what counts)."""
    reference, other = Path(reference), Path(other)
    ref_files, other_files = _files(reference), _files(other)
    worst, worst_name = 0.0, ""
    keys: list[str] = []
    values: list[str] = []
    for name in sorted(ref_files & other_files):
        suffix = Path(name).suffix
        if suffix in (".npz", ".onnx"):
            read = npz_arrays if suffix == ".npz" else onnx_arrays
            a, b = read(reference / name), read(other / name)
            for key in sorted(set(a) | set(b)):
                d = _array_diff(a[key], b[key]) if key in a and key in b else float("inf")
                if d > worst or (d == worst and not worst_name and d > 0):
                    worst, worst_name = d, f"{name}:{key}"
        elif suffix == ".json":
            found: list[str] = []
            _json_diff(json.loads((reference / name).read_text()), json.loads((other / name).read_text()),
                       "", found, values, tolerance)
            keys += [f"{name}:{k}" for k in found]
        elif (reference / name).read_bytes() != (other / name).read_bytes():
            worst, worst_name = float("inf"), name
    return AvatarDiff(tuple(sorted(ref_files - other_files)), tuple(sorted(other_files - ref_files)), worst,
                      worst_name, tuple(keys), tuple(values), tolerance)


# ---- running, killing and reading ``morf run`` ---------------------------------------------

_STATUS = re.compile(r"^\[(\d+)/(\d+)\] (\w+): (.*)$")


def morf_argv(*args: str) -> list[str]:
    """A ``morf`` command line for this interpreter (the same code and environment as this one)."""
    return [sys.executable, "-c", "import sys; from morf.cli.main import main; sys.exit(main())", *args]


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


def run_to_end(argv: list[str], log_path: Path, timeout: float = 1800) -> tuple[int, float]:
    """Run a command to its end with its output in ``log_path``; (exit status, seconds)."""
    t0 = time.monotonic()
    with open(log_path, "wb") as log:
        rc = subprocess.call(argv, stdout=log, stderr=subprocess.STDOUT, env=_environment(), timeout=timeout)
    return rc, time.monotonic() - t0


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


def kill_times(duration: float, kills: int, seed: int) -> list[float]:
    """``kills`` times in [0, duration): one uniform draw in each of ``kills`` equal slices."""
    rng = np.random.default_rng(seed)
    width = duration / kills
    return [round(float((i + rng.random()) * width), 3) for i in range(kills)]


# ---- the benchmark --------------------------------------------------------------------------

@dataclass(frozen=True)
class KillRow:
    """One kill: when (``at_s``), what it hit, what the next ``morf run`` did, and the avatar's
    difference from the reference's (``diff``, :class:`AvatarDiff`; None when no avatar came)."""

    kill: int
    at_s: float
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
              after: Callable[[Path], bool] | None = None) -> KillRow:
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
    rc, _ = run_to_end(argv_for(project), work / "again.log")
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
    return KillRow(index, at_s, stage, second_run_word(stage, actions), actions, rc, diff, note)


def _last_line(log: str) -> str:
    lines = [line.strip() for line in re.split(r"[\r\n]+", log) if line.strip()]
    return lines[-1][:200] if lines else ""


def add_arguments(p):
    p.add_argument("--out", required=True, help="output folder for resume.json / resume.md (and the work files)")
    p.add_argument("--kills", type=int, default=20, help="kills, spread over the uninterrupted run's duration")
    p.add_argument("--seed", type=int, default=0, help="seed of the kill times (stratified random)")
    p.add_argument("--preset", default="tiny", help="synth and 'morf run' preset (default tiny)")
    p.add_argument("--tolerance", type=float, default=1e-5, help="largest absolute difference allowed in any array")
    p.add_argument("--keep", action="store_true", help="keep every kill's project copy (default: only failed ones)")


def run(args) -> int:
    from morf.bench.common import machine_info, markdown_table, write_results
    from morf.errors import InputError, ProjectError

    if args.kills < 1:
        raise InputError(f"--kills must be at least 1, got {args.kills}")
    if not args.tolerance >= 0:
        raise InputError(f"--tolerance must be >= 0, got {args.tolerance}")
    out = Path(args.out)
    work = out / "work"
    capture = work / "capture"
    if capture.exists():
        shutil.rmtree(capture)
    capture.parent.mkdir(parents=True, exist_ok=True)
    rc, _ = run_to_end(morf_argv("synth", str(capture), "--preset", args.preset), work / "synth.log")
    if rc != 0:
        raise ProjectError(f"morf synth failed (exit {rc}); see {work / 'synth.log'}")

    def argv_for(project: Path) -> list[str]:
        return morf_argv("run", str(project), "--preset", args.preset)

    ref = work / "reference"
    if ref.exists():
        shutil.rmtree(ref)
    ref.mkdir()
    shutil.copytree(capture, ref / "P")
    rc, duration = run_to_end(argv_for(ref / "P"), ref / "run.log")
    if rc != 0:
        raise ProjectError(f"the uninterrupted morf run failed (exit {rc}); see {ref / 'run.log'}")
    reference = ref / "P" / "avatar"
    print(f"reference: morf run in {duration:.1f} s; {args.kills} kills over it")
    rows = []
    for i, at in enumerate(kill_times(duration, args.kills, args.seed)):
        kill_dir = work / f"kill-{i:02d}"
        row = kill_once(capture, kill_dir, argv_for, at, reference, i, args.tolerance)
        rows.append(row)
        print(f"kill {i:2d} at {at:6.2f} s in {row.stage_killed:<13} second run {row.second_run:<28} "
              f"{'pass' if row.passed else 'FAIL'} max diff {row.diff.max_abs_diff if row.diff else 'n/a'}")
        if row.passed and not args.keep:
            shutil.rmtree(kill_dir / "P", ignore_errors=True)
    passed = sum(r.passed for r in rows)
    result = {"benchmark": "resume", "preset": args.preset, "kills": args.kills, "seed": args.seed,
              "tolerance": args.tolerance, "reference_seconds": round(duration, 2), "passed": passed,
              "rows": [r.to_dict() for r in rows], "machine": machine_info(),
              "command": f"morf bench resume --out {args.out} --kills {args.kills} --seed {args.seed}"}
    table = [{**r.to_dict(), "passed": "pass" if r.passed else "FAIL",
              "max_abs_diff": "n/a" if r.diff is None else f"{r.diff.max_abs_diff:.3g}",
              "worst": (r.diff.worst if r.diff else "") or "-", "note": r.note or "-"} for r in rows]
    md = (f"# morf bench resume\n\n`morf run P --preset {args.preset}` on a `morf synth --preset {args.preset}` capture: "
          f"uninterrupted in {duration:.1f} s; then {args.kills} runs sent SIGKILL (the whole process group) at a "
          f"stratified random time (seed {args.seed}), each followed by `morf run` to the end, and the exported "
          f"avatar compared with the uninterrupted run's (same files, arrays within {args.tolerance:g}). "
          f"**{passed} of {len(rows)} passed.**\n\nCPU: {result['machine']['cpu']}\n\n"
          + markdown_table(table, COLUMNS))
    path = write_results(out, "resume", result, md)
    print(f"{passed} of {len(rows)} kills ended with the reference avatar; wrote {path}")
    return 0 if passed == len(rows) else 1
