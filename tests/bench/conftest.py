"""Fixtures of the benchmark tests: one tiny synthetic capture that the sweep tests share.

The sweep trains each distinct config once per capture (``ROOT/runs/pareto-<config key>``), so
tests that measure points on the same capture reuse each other's trainings instead of training
the base point again: the trainings, not the checks, are what takes the time. The suite hands
whole files to its workers, so the tests that train on this capture live in one file
(test_pareto.py): split across files they would each make the capture and train the points again.
"""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def sweep_dir(tmp_path_factory):
    """A folder of this test session for the tiny sweep: its capture and the shared results."""
    return tmp_path_factory.mktemp("tiny-sweep")


@pytest.fixture(scope="module")
def print_capture(sweep_dir, body_model, gl):
    """The tiny sweep's "print" capture, made by the sweep's own code where ``morf bench pareto
    --preset tiny --out SWEEP_DIR/pareto`` makes it (made once a session, opened after that)."""
    from morf.bench.pareto import make_capture
    from morf.presets import preset

    return make_capture(sweep_dir / "pareto", preset("sweep", "tiny"), "print", body_model)
