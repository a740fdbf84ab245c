"""The training runs already on disk (``PROJECT/runs/<name>/``), as the Training panel lists them.

Read from the small files only, through :mod:`morf.train.run_files` (config.json, the last step of
metrics.jsonl, avatar.pt's presence), and ``PROJECT/eval/eval.json``; nothing here imports torch or
loads a model.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from morf.train.run_files import RunFiles


@dataclass(frozen=True)
class RunSummary:
    name: str
    method: str
    preset: str
    steps: int  # the run's planned steps
    step: int  # the last step metrics.jsonl recorded (0: none)
    finished: bool  # avatar.pt written
    holdout_psnr: float | None  # person PSNR on its held-out frames from PROJECT/eval/eval.json

    @property
    def status(self) -> str:
        if self.method == "rgb":
            return "built (no training)" if self.finished else "not built"
        if self.finished:
            return f"finished, {self.steps} steps"
        return f"step {self.step} of {self.steps}, not finished" if self.step else "not started"


def _holdout_scores(project_root: Path) -> dict[str, float]:
    """Run name -> person PSNR on its held-out capture frames, from the project's last ``morf eval``."""
    path = project_root / "eval" / "eval.json"
    try:
        runs = json.loads(path.read_text()).get("runs", {})
    except (OSError, json.JSONDecodeError, AttributeError):
        return {}
    out = {}
    for name, entry in runs.items():
        for key, metrics in (entry.get("targets") or {}).items():
            psnr = (metrics or {}).get("psnr_person")
            if key.startswith("holdout") and psnr is not None:
                out[name] = float(psnr["mean"] if isinstance(psnr, dict) else psnr)
    return out


def read_runs(project_root: str | Path) -> list[RunSummary]:
    """Every run folder with a readable config.json, newest first; damaged ones are skipped."""
    root = Path(project_root)
    runs_dir = root / "runs"
    if not runs_dir.is_dir():
        return []
    scores = _holdout_scores(root)
    found = []
    for d in runs_dir.iterdir():
        run = RunFiles(d)
        if d.name.startswith(".") or not run.config_path.is_file():
            continue
        try:
            cfg = run.read_config_dict()
            summary = RunSummary(d.name, str(cfg.get("method", "?")), str(cfg.get("preset", "?")),
                                 int(cfg.get("steps", 0)), run.last_step(), run.is_done, scores.get(d.name))
        except (OSError, json.JSONDecodeError, TypeError, ValueError, AttributeError):
            continue
        found.append((run.config_path.stat().st_mtime, summary))
    return [s for _, s in sorted(found, key=lambda t: -t[0])]
