"""``morf bench fitting --command-runs N``: the whole 'morf fit' command timed in a fresh process."""

import json

from morf.cli.main import main


def test_bench_fitting_times_the_whole_fit_command_on_a_copy(tmp_path):
    out = tmp_path / "bench"
    rc = main(["bench", "fitting", "--out", str(out), "--preset", "tiny", "--frames", "6", "--fit-preset", "tiny",
               "--configs", "all", "--command-runs", "1"])
    assert rc == 0
    result = json.loads((out / "fitting.json").read_text())
    cmd = result["command"]
    assert len(cmd["seconds"]) == 1 and cmd["seconds"][0] > 0
    assert cmd["frames_per_second"][0] == result["capture"]["frames"] / cmd["seconds"][0]
    assert "--preset tiny" in cmd["command"]
    assert "whole command" in (out / "fitting.md").read_text()
    # the timed runs fitted a copy: the capture's own folder holds no fits from them
    assert not (out / "capture" / "fits" / "fits.npz").exists()
