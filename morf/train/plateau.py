"""When did a training run stop improving? Read from its ``metrics.jsonl`` (no evaluation needed).

The per-step L1 is noisy (a batch of a few random frames), so it is averaged over windows of a
tenth of the run. The plateau is the end of the first window whose mean is within ``tolerance``
(relative) of the last window's mean: from then on the run gained less than that. Reported in
minutes of training time (``time_s`` of the log, which excludes time the run was stopped).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from morf.train.run_files import METRICS_FILE, read_metrics_file


@dataclass(frozen=True)
class Plateau:
    """Where a run stopped improving.

    Fields:
        step: the training step the plateau starts at; minutes: training minutes up to it;
        final: the metric's mean over the last window; tolerance: relative, the gain left from
        ``step`` on is below it; key: the metric (a metrics.jsonl field, e.g. "l1").
    """

    step: int
    minutes: float
    final: float
    tolerance: float
    key: str

    def to_dict(self) -> dict:
        return asdict(self)


def plateau(rows: list[dict], key: str = "l1", tolerance: float = 0.05, windows: int = 10) -> Plateau | None:
    """The plateau of ``key``, or None with too few lines.

    Args:
        rows: metric lines with "step", "time_s" and ``key``, in step order.
    """
    rows = [r for r in rows if key in r and "time_s" in r and np.isfinite(r[key])]
    if len(rows) < 2 * windows:
        return None
    values = np.array([r[key] for r in rows], np.float64)
    w = len(values) // windows
    means = np.convolve(values, np.ones(w) / w, mode="valid")  # means[i] = mean of values[i : i + w]
    final = means[-1]
    ok = np.nonzero(means <= final * (1 + tolerance))[0]
    end = int(ok[0]) + w - 1
    return Plateau(int(rows[end]["step"]), float(rows[end]["time_s"]) / 60, float(final), tolerance, key)


def run_plateau(run_dir: str | Path, **kwargs) -> Plateau | None:
    path = Path(run_dir) / METRICS_FILE
    return plateau(read_metrics_file(path), **kwargs) if path.is_file() else None
