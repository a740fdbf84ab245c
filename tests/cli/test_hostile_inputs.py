"""Hostile and mistaken inputs through the real commands, as a user runs them (docs/hostile-inputs.md).

Each case runs ``morf ...`` in a folder of its own and must end with the exit code it is allowed
(2 for a user error), print a user error as exactly one line ``morf CMD: error: ...`` on stderr,
never a traceback or a leaked numpy warning, and change nothing under its folder (the project, the
user's other files) except the command's own output.

The capture the cases use (a tiny synthetic one, fitted, trained and exported) is built once per
session through the CLI; each case copies what it needs. Most cases run the command in this
process through its entry point (``morf.cli.main.main``, :func:`hostile_runner.run_in_process`),
which spares each the seconds a fresh interpreter takes to start; the few in ``FRESH_PROCESS`` run
``python -m morf.cli.main`` as a shell would, two at a time (``MORF_HOSTILE_JOBS``), started as
soon as the first hostile test runs, while the others run one by one in the test's own thread.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import subprocess
import sys
import time
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import hostile_files as hf  # noqa: E402
from hostile_cases import CASES, Case, by_id  # noqa: E402
from hostile_runner import Fixture, Outcome, changes, command_env, morf_command, run_case, snapshot  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "hostile-inputs.md"
JOBS = int(os.environ.get("MORF_HOSTILE_JOBS", "2"))

# The cases that run in a fresh ``python -m morf.cli.main`` process, as typed in a shell: one of each
# way a command ends on bad input (an output it refuses, an option out of range, a lock another
# process holds, a read-only project, a full disk); those whose failure could take the test process
# down with it (a file that claims or expands to huge arrays, a native video decoder fed text); and
# those that run MediaPipe, whose module sets a process-wide warning filter when first imported
# (the in-process runner starts every case from Python's default filters, so it would report the
# warning that filter hides). Everything the others are checked on is checked on these the same way.
FRESH_PROCESS = frozenset({"export-out-is-a-file", "play-fps-nan", "lock-train-same-run", "read-only-export",
                           "export-out-dev-full", "npz-zip-bomb", "npz-claims-huge-array", "ingest-video-is-text",
                           "openpose-good", "ingest-video-without-person", "run-video-without-person"})


def _morf(args: list[str], cwd: Path, timeout: int = 600) -> subprocess.CompletedProcess:
    p = subprocess.run(morf_command() + args, cwd=cwd, env=command_env(), capture_output=True, text=True,
                       timeout=timeout)
    if p.returncode != 0:
        raise RuntimeError(f"building the hostile-input capture: morf {' '.join(args)} exited {p.returncode}:\n"
                           f"{p.stderr[-3000:]}")
    return p


@pytest.fixture(scope="session")
def hostile_fixture(tmp_path_factory) -> Fixture:
    """A tiny synthetic capture, fitted, trained and exported (``morf synth --preset tiny``, then
    ``morf run --preset tiny``), a good BVH and a zip bomb; built once, read-only by convention."""
    root = tmp_path_factory.mktemp("hostile-fixture")
    seconds = {}
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    bvh = subprocess.Popen(morf_command() + ["motion", "export", str(hf.CLIP), "--out", "walk.bvh"], cwd=root,
                           env=command_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _morf(["synth", "P", "--preset", "tiny"], root)
    seconds["synth"] = time.perf_counter() - t0
    _morf(["run", "P", "--preset", "tiny"], root)
    seconds["run"] = time.perf_counter() - t0 - seconds["synth"]
    t1 = time.perf_counter()
    hf.npz_deflate_bomb(root / "bomb.npz")
    seconds["bomb"] = time.perf_counter() - t1
    _, err = bvh.communicate(timeout=600)
    if bvh.returncode != 0:
        raise RuntimeError(f"building the hostile-input BVH: morf motion export exited {bvh.returncode}:\n{err[-3000:]}")
    seconds["total"] = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    seconds["commands_cpu"] = cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime
    for name in ("avatar/manifest.json", "runs/morf-tiny/avatar.pt", "fits/fits.npz"):
        assert (root / "P" / name).is_file(), f"the fixture capture has no {name}"
    return Fixture(project=root / "P", bvh=root / "walk.bvh", bomb=root / "bomb.npz", seconds=seconds)


@pytest.fixture(scope="session")
def fixture_before(hostile_fixture) -> dict:
    """The shared capture as built, to check at the end that no case changed it."""
    return snapshot(hostile_fixture.project.parent)


@pytest.fixture(scope="session")
def case_root(tmp_path_factory) -> Path:
    """The folder that holds one folder per case."""
    return tmp_path_factory.mktemp("hostile-cases")


@pytest.fixture(scope="session")
def outcomes(request, hostile_fixture, fixture_before, case_root):
    """case id -> Future[Outcome]: the selected ``FRESH_PROCESS`` cases, run ``JOBS`` at a time in
    test order from the start; each in-process case adds its own when its test runs it."""
    wanted = [item.callspec.params["case"] for item in request.session.items
              if getattr(item, "originalname", None) == "test_hostile_input" and hasattr(item, "callspec")]
    pool = ThreadPoolExecutor(max_workers=max(1, JOBS))
    futures: dict[str, Future] = {c.id: pool.submit(run_case, c, hostile_fixture, case_root / c.id)
                                  for c in wanted if c.id in FRESH_PROCESS}
    yield futures
    pool.shutdown(wait=True, cancel_futures=True)
    if os.environ.get("MORF_HOSTILE_REPORT"):
        _write_report(Path(os.environ["MORF_HOSTILE_REPORT"]), hostile_fixture, wanted, futures)


def _write_report(path: Path, fixture: Fixture, wanted: list[Case], futures: dict[str, Future]) -> None:
    """Every case's exit code, time and first stderr lines, and what it does wrong, as JSON."""
    rows = []
    for c in wanted:
        f = futures.get(c.id)
        if f is None:
            rows.append({"id": c.id, "area": c.area, "error": "not run"})
            continue
        if f.cancelled() or f.exception() is not None:
            rows.append({"id": c.id, "area": c.area, "error": repr(f.exception()) if not f.cancelled() else "cancelled"})
            continue
        out = f.result()
        rows.append({"id": c.id, "area": c.area, "fresh_process": c.id in FRESH_PROCESS, "rc": out.rc,
                     "seconds": round(out.seconds, 2),
                     "cpu_seconds": round(out.cpu_seconds, 2), "skipped": out.skipped,
                     "stderr": error_lines(out.stderr)[:4], "problems": out.problems})
    path.write_text(json.dumps({"fixture_seconds": fixture.seconds, "cases": rows}, indent=1))


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.strip()]


def problems_of(case: Case, out: Outcome) -> list[str]:
    """Everything the outcome does wrong, in words (empty: the case passes)."""
    bad = []
    lines = error_lines(out.stderr)
    if out.rc not in case.rc:
        bad.append(f"exit code {out.rc}, expected {' or '.join(map(str, case.rc))}")
    if "Traceback" in out.stderr:
        bad.append("stderr holds a traceback")
    if "Warning:" in out.stderr:
        bad.append("stderr holds a leaked Python warning")
    for line in lines:  # a command speaks in its own name (animate's messages are not "morf play:")
        if line.startswith("morf ") and ":" in line:
            who = line[5:].split(":", 1)[0]
            if who not in (case.cmd, case.error_from) and " " not in who:
                bad.append(f"a message of morf {case.cmd} speaks as 'morf {who}': {line[:200]}")
    if out.rc != 0:  # any failure is reported as one line
        who = case.error_from or case.cmd
        allowed = 2 if case.hint else 1
        first = lines[0] if lines else ""
        if not first.startswith(f"morf {who}: error:"):
            bad.append(f"stderr's first line is not 'morf {who}: error: ...'")
        if len(lines) != 1 and not (case.hint and len(lines) == allowed):
            bad.append(f"stderr has {len(lines)} non-empty lines, expected {allowed}")
        if case.hint and case.hint not in out.stderr + out.stdout:
            bad.append(f"the retry hint does not hold {case.hint!r}")
        for text in case.says:
            text = text.format(holder_pid=out.holder_pid)
            if text not in first:
                bad.append(f"the error line does not say {text!r}")
        for text in case.never_says:
            if text in out.stderr:
                bad.append(f"stderr says {text!r}")
    changed = changes(out.before, out.after)
    allowed_paths = case.own if out.rc == 0 else ()
    outside = {p: how for p, how in changed.items()
               if not any(p == o or p.startswith(o + "/") for o in allowed_paths)
               or any(p == k or p.startswith(k + "/") for k in case.keep)}
    if outside:
        shown = ", ".join(f"{p} ({how})" for p, how in list(outside.items())[:8])
        more = f" and {len(outside) - 8} more" if len(outside) > 8 else ""
        bad.append(f"changed outside the command's own output: {shown}{more}")
    if case.check is not None and out.rc == 0:
        problem = case.check(out.folder, out)
        if problem:
            bad.append(problem)
    return bad


def outcome_of(case: Case, outcomes: dict[str, Future], fixture: Fixture, root: Path) -> Outcome:
    """The case's outcome: its fresh process's when it has one, else run now in this thread."""
    if case.id not in outcomes:
        done: Future = Future()
        outcomes[case.id] = done
        try:
            done.set_result(run_case(case, fixture, root / case.id, in_process=True))
        except BaseException as e:
            done.set_exception(e)
    return outcomes[case.id].result()


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_hostile_input(case: Case, outcomes, hostile_fixture, case_root):
    out = outcome_of(case, outcomes, hostile_fixture, case_root)
    if out.skipped:
        pytest.skip(out.skipped)
    bad = out.problems = problems_of(case, out)
    if bad:
        head = "\n    ".join(error_lines(out.stderr)[:4]) or "(empty)"
        pytest.fail(f"morf {' '.join(out.argv)}\n  expected: {case.expect}\n  problems: " + "; ".join(bad)
                    + f"\n  rc {out.rc} in {out.seconds:.1f} s; stderr:\n    {head}", pytrace=False)
    shutil.rmtree(out.folder, ignore_errors=True)  # a passing case's folder is of no further use


def test_shared_fixture_unchanged(hostile_fixture, fixture_before, outcomes):
    """Cases read the shared capture (ingest takes its frames); none may change it."""
    for f in outcomes.values():
        f.exception()  # wait for every case
    assert changes(fixture_before, snapshot(hostile_fixture.project.parent)) == {}


def test_docs_list_every_case():
    """docs/hostile-inputs.md names every case the suite tries."""
    text = DOC.read_text()
    missing = [c.id for c in CASES if f"`{c.id}`" not in text]
    assert not missing, f"{DOC} does not list {missing}"
    assert len(by_id()) >= 60


def test_checker_finds_what_it_must():
    """The checks above can fail: a changed file, a traceback, a second line, a wrong exit code, a
    changed file of the user's inside a --force output."""
    refused = Case("t-refused", "t", "export P --out d", "refused")
    same = {"P/a.npz": ("file", 3, "aa", 1), "d/keep.txt": ("file", 2, "bb", 1)}

    def outcome(rc, stderr, after=None):
        return Outcome(argv=[], rc=rc, stderr=stderr, before=dict(same), after=dict(after or same))

    assert problems_of(refused, outcome(2, "morf export: error: d holds keep.txt\n")) == []
    bad = problems_of(refused, outcome(2, "morf export: error: x\n", {**same, "P/a.npz": ("file", 3, "cc", 2)}))
    assert any("P/a.npz (changed)" in b for b in bad)
    bad = problems_of(refused, outcome(1, "Traceback (most recent call last):\n  File x\nValueError: y\n"))
    assert any("exit code 1" in b for b in bad) and any("traceback" in b for b in bad)
    assert any("3 non-empty lines" in b for b in bad)
    assert problems_of(refused, outcome(0, "")) == ["exit code 0, expected 2"]
    forced = Case("t-forced", "t", "export P --out d --force", "works", rc=(0,), own=("d",), keep=("d/keep.txt",))
    assert problems_of(forced, outcome(0, "", {**same, "d/mesh.npz": ("file", 1, "dd", 1)})) == []
    bad = problems_of(forced, outcome(0, "", {"P/a.npz": same["P/a.npz"]}))
    assert bad == ["changed outside the command's own output: d/keep.txt (removed)"]
    animate = Case("t-animate", "t", "animate P --motion m.bvh --out o.mp4", "refused")
    bad = problems_of(animate, outcome(2, "morf animate: error: m.bvh: NaN\nmorf play: warning: slow\n"))
    assert any("speaks as 'morf play'" in b for b in bad)
