"""A run's stored playback speed: read back while the run, the settings and the machine are the
ones it was measured with, measured again when any of them changed."""

import os

from morf.bench import run_speed
from morf.bench.train_eval import PlaybackSpeed, RunSpeed


def test_a_run_is_timed_once_per_identity(tmp_path, monkeypatch):
    run = tmp_path / "runs" / "r"
    run.mkdir(parents=True)
    (run / "avatar.pt").write_bytes(b"weights")
    timed = []

    def fake_speed_of_run(run_dir, work, size, frames, precision, body_model):
        timed.append((size, precision))
        return RunSpeed(PlaybackSpeed(100.0 + len(timed), 10.0, 5.0, 45.0), 40.0)

    monkeypatch.setattr("morf.bench.train_eval.speed_of_run", fake_speed_of_run)
    first, reused = run_speed.speed_of_run_once(run, tmp_path / "work", 64, 8, "int8", None)
    assert not reused and first.playback.fps == 101.0
    again, reused = run_speed.speed_of_run_once(run, tmp_path / "other-work", 64, 8, "int8", None)
    assert reused and again == first and len(timed) == 1
    # another precision or size is another measurement
    assert not run_speed.speed_of_run_once(run, tmp_path / "work", 64, 8, "fp32", None)[1]
    assert not run_speed.speed_of_run_once(run, tmp_path / "work", 128, 8, "int8", None)[1]
    # the run trained further (a new avatar.pt): measured again, and the new number kept
    st = (run / "avatar.pt").stat()
    os.utime(run / "avatar.pt", ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    later, reused = run_speed.speed_of_run_once(run, tmp_path / "work", 64, 8, "int8", None)
    assert not reused and later.playback.fps == 104.0
    assert run_speed.speed_of_run_once(run, tmp_path / "work", 64, 8, "int8", None) == (later, True)
    # another machine's number is not this one's
    real_identity = run_speed.speed_identity
    monkeypatch.setattr(run_speed, "speed_identity", lambda *a: {**real_identity(*a), "cpu": "another CPU"})
    assert not run_speed.speed_of_run_once(run, tmp_path / "work", 64, 8, "int8", None)[1]
    # a damaged file is measured again, not an error
    path = run_speed.stored_speed_path(run, 64, 8, "int8")
    path.write_text("{not json")
    monkeypatch.undo()
    monkeypatch.setattr("morf.bench.train_eval.speed_of_run", fake_speed_of_run)
    assert not run_speed.speed_of_run_once(run, tmp_path / "work", 64, 8, "int8", None)[1]
