"""The Training panel's list of the runs already on disk."""

import json

from studio.run_list import read_runs


def _run(root, name, method="morf", steps=100, last=None, done=False):
    d = root / "runs" / name
    d.mkdir(parents=True)
    (d / "config.json").write_text(json.dumps({"method": method, "preset": "cpu", "steps": steps}))
    if last is not None:
        lines = [json.dumps({"step": s}) for s in range(10, last + 1, 10)]
        (d / "metrics.jsonl").write_text("\n".join(lines) + "\n{\"step\": 9")  # the last line cut by a kill
    if done:
        (d / "avatar.pt").write_bytes(b"")
    return d


def test_runs_on_disk_with_their_status_and_held_out_score(tmp_path):
    assert read_runs(tmp_path) == []
    _run(tmp_path, "a", last=100, done=True)
    _run(tmp_path, "b", last=40)
    _run(tmp_path, "floor", method="rgb", steps=0, done=True)
    (tmp_path / "runs" / "broken").mkdir()
    (tmp_path / "runs" / "broken" / "config.json").write_text("{not json")
    (tmp_path / "runs" / ".cache").mkdir()
    (tmp_path / "eval").mkdir()
    (tmp_path / "eval" / "eval.json").write_text(json.dumps({"runs": {"a": {"targets": {
        "holdout-k5": {"psnr_person": 20.5}, "novel-poses": {"psnr_person": 19.0}}}}}))
    runs = {r.name: r for r in read_runs(tmp_path)}
    assert set(runs) == {"a", "b", "floor"}
    assert runs["a"].status == "finished, 100 steps" and runs["a"].holdout_psnr == 20.5
    assert runs["b"].status == "step 40 of 100, not finished" and runs["b"].holdout_psnr is None
    assert runs["floor"].status == "built (no training)"
