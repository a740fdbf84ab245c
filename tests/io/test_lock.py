"""One writer per project stage: a second process is refused with the holder named; a killed
holder's lock is free again; within one process the lock is re-entrant."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from morf.errors import ProjectError
from morf.io.lock import acquire, holder_of, lock_path, project_lock, release

HOLD = """
import sys, time
from morf.io.lock import project_lock
with project_lock(sys.argv[1], "fit", "morf fit P"):
    print("held", flush=True)
    time.sleep(60)
"""


def hold_in_another_process(root):
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(root)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


def test_second_writer_is_refused_and_a_killed_holder_frees_the_lock(tmp_path):
    p = hold_in_another_process(tmp_path)
    try:
        assert holder_of(tmp_path, "fit")["pid"] == p.pid
        with pytest.raises(ProjectError, match=rf"body fit is being written by another morf process \(pid {p.pid}, "
                                               r"`morf fit P`"):
            with project_lock(tmp_path, "fit"):
                pass
        with project_lock(tmp_path, "export"):  # another stage is free
            pass
    finally:
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
    assert holder_of(tmp_path, "fit") is None
    with project_lock(tmp_path, "fit", "morf fit again"):  # taken over
        assert '"morf fit again"' in lock_path(tmp_path, "fit").read_text()
    assert lock_path(tmp_path, "fit").read_text() == ""  # free: no holder named


def test_reentrant_within_a_process(tmp_path):
    a = acquire(tmp_path, "run-x")
    b = acquire(tmp_path, "run-x")
    assert a == b
    release(b)
    p = subprocess.run([sys.executable, "-c", "import sys\nfrom morf.io.lock import acquire\nacquire(sys.argv[1], 'run-x')",
                        str(tmp_path)], capture_output=True, text=True)
    assert p.returncode != 0 and "the training run 'x' is being written" in p.stderr  # still held once
    release(a)
    p = subprocess.run([sys.executable, "-c", "import sys\nfrom morf.io.lock import acquire\nacquire(sys.argv[1], 'run-x')",
                        str(tmp_path)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def test_read_only_project_is_one_line(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    tmp_path.chmod(0o500)
    try:
        with pytest.raises(ProjectError, match="must be writable"):
            acquire(tmp_path, "fit")
    finally:
        tmp_path.chmod(0o700)
