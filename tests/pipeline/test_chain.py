"""Chained stages: skipped, resumed and run steps, one status line each; a failure or a stop ends
the chain with a line that says how to continue."""

from __future__ import annotations

import pytest

from morf.pipeline.chain import Plan, Step, run_steps


def chain(plans):
    return [Step(name, (lambda p=plan: p)) for name, plan in plans]


def test_skip_resume_run_lines_and_commands_in_order():
    ran, lines = [], []
    steps = chain([("ingest", Plan("skip", note="12 frames")),
                   ("fit", Plan("resume", ("fit", "P"), "after stage 2 of 3")),
                   ("train", Plan("run", ("train", "P", "--preset", "tiny")))])
    rc = run_steps(steps, lambda argv: ran.append(argv) or 0, "run", "morf run P", lines.append)
    assert rc == 0
    assert ran == [["fit", "P"], ["train", "P", "--preset", "tiny"]]
    assert lines[0] == "[1/3] ingest: skipped (already done: 12 frames)"
    assert lines[1] == "[2/3] fit: resuming (after stage 2 of 3): morf fit P"
    assert lines[2].startswith("[2/3] fit: resumed and done in ")
    assert lines[3] == "[3/3] train: morf train P --preset tiny"
    assert lines[4].startswith("[3/3] train: done in ")


def test_plans_are_made_when_their_step_starts():
    state = {"fitted": False}

    def fit(argv):
        state["fitted"] = True
        return 0

    steps = [Step("fit", lambda: Plan("run", ("fit", "P"))),
             Step("check", lambda: Plan("skip") if state["fitted"] else Plan("run", ("never",)))]
    lines = []
    assert run_steps(steps, fit, "run", "morf run P", lines.append) == 0
    assert lines[-1] == "[2/2] check: skipped (already done)"


@pytest.mark.parametrize("rc, words", [(2, "fit failed (exit 2); fix it and continue with: morf run P"),
                                        (130, "stopped during fit; to continue from there, run: morf run P")])
def test_a_failed_or_stopped_step_ends_the_chain(rc, words):
    ran, lines = [], []
    steps = chain([("fit", Plan("run", ("fit", "P"))), ("train", Plan("run", ("train", "P")))])
    assert run_steps(steps, lambda argv: ran.append(argv) or rc, "run", "morf run P", lines.append) == rc
    assert ran == [["fit", "P"]]
    assert lines[-1] == f"morf run: {words}"  # the command last on the line: it can be pasted as it is


def test_plan_checks_its_fields():
    with pytest.raises(ValueError):
        Plan("later")
    with pytest.raises(ValueError):
        Plan("run")
