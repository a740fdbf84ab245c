"""What the view-colour and head-colour run tests both do through the commands a user runs."""

from __future__ import annotations

import json

from morf.cli.main import main


def eval_person_psnr(project, run: str, out, target: str = "holdout-k3") -> float:
    """``morf eval`` of ``run`` (no floor, no detail scores) into ``out``: ``target``'s person PSNR."""
    assert main(["eval", str(project.root), "--run", run, "--no-floor", "--no-detail", "--out", str(out)]) == 0
    ev = json.loads((out / "eval.json").read_text())
    return float(ev["runs"][run]["targets"][target]["psnr_person"])


def export_run(project, run: str, out) -> dict:
    """``morf export`` of ``run`` into ``out`` (2 calibration views): the folder's manifest."""
    assert main(["export", str(project.root), "--run", run, "--out", str(out), "--calibration-views", "2"]) == 0
    return json.loads((out / "manifest.json").read_text())
