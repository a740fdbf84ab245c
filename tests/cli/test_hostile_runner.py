"""The in-process runner of the hostile cases sees what a fresh ``morf`` process shows: the exit
code, Python's and C libraries' output, warnings, tracebacks; and it leaves this process as it was."""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import hostile_runner as hr  # noqa: E402
from hostile_cases import by_id  # noqa: E402
from test_hostile_inputs import FRESH_PROCESS  # noqa: E402


def test_fresh_process_cases_exist():
    assert FRESH_PROCESS <= set(by_id()), sorted(FRESH_PROCESS - set(by_id()))


@pytest.mark.parametrize("argv", [
    ["info", "no-such-project"],  # a user error: one line, exit code 2
    ["play", "A", "--motion", "m.npz"],  # argparse: usage and error, exit code 2
    ["info", "P", "--no-such-option"],
], ids=["user-error", "missing-option", "unknown-option"])
def test_same_as_a_fresh_process(argv, tmp_path):
    fresh = hr.run_command(hr.morf_command() + argv, tmp_path)[:3]
    here = hr.run_in_process(argv, tmp_path)[:3]
    assert here == fresh
    assert fresh[0] == 2 and fresh[2].strip()


def _noisy_main(argv):
    """Stands in for morf's entry point: output at both levels, a warning, then a crash."""
    print("said on stdout")
    os.write(2, b"written to fd 2 by a C library\n")
    warnings.warn("overflow in a cast", RuntimeWarning)
    warnings.warn("old API", DeprecationWarning)  # hidden in a fresh process too
    assert os.environ["MORF_QUIET"] == "1" and "MORF_DEBUG" not in os.environ
    assert Path.cwd() == Path(argv[0])
    raise ValueError("a bug")


def test_catches_what_a_process_would_show(tmp_path, monkeypatch):
    import morf.cli.main

    monkeypatch.setattr(morf.cli.main, "main", _noisy_main)
    monkeypatch.setenv("MORF_DEBUG", "1")
    cwd, env = os.getcwd(), dict(os.environ)
    rc, out, err, _ = hr.run_in_process([str(tmp_path.resolve())], tmp_path)
    assert rc == 1
    assert out == "said on stdout\n"
    assert "written to fd 2 by a C library" in err
    assert "RuntimeWarning: overflow in a cast" in err and "DeprecationWarning" not in err
    assert "Traceback (most recent call last)" in err and "ValueError: a bug" in err
    assert os.getcwd() == cwd and dict(os.environ) == env  # put back as it was


def test_exit_codes_of_system_exit(tmp_path, monkeypatch):
    import morf.cli.main

    for code, rc in ((None, 0), (3, 3), ("a message", 1)):
        def leave(argv, code=code):
            raise SystemExit(code)

        monkeypatch.setattr(morf.cli.main, "main", leave)
        got = hr.run_in_process([], tmp_path)
        assert got[0] == rc
        assert ("a message" in got[2]) == (code == "a message")
