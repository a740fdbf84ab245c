"""Plateau detection on training logs with a known curve."""

import json

import numpy as np

from morf.train.plateau import plateau
from morf.train.run_files import read_metrics_file as read_metrics


def _rows(n=1000, tau=100.0, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    steps = np.arange(1, n + 1)
    l1 = 0.05 + 0.5 * np.exp(-steps / tau) + noise * rng.standard_normal(n)
    return [{"step": int(s), "time_s": float(s) * 0.6, "l1": float(v)} for s, v in zip(steps, l1)]


def test_plateau_of_an_exponential_decay():
    p = plateau(_rows())
    # the last-window mean is ~0.05; within 5% once 0.5 exp(-s/100) averaged over 100 steps < 0.0025
    assert 500 < p.step < 650
    assert abs(p.minutes - p.step * 0.6 / 60) < 1e-9
    assert abs(p.final - 0.05) < 1e-3
    assert p.to_dict() == {"step": p.step, "minutes": p.minutes, "final": p.final, "tolerance": 0.05, "key": "l1"}


def test_slower_decay_plateaus_later_and_noise_is_averaged():
    assert plateau(_rows(tau=200)).step > plateau(_rows(tau=100)).step
    assert abs(plateau(_rows(noise=0.01)).step - plateau(_rows()).step) < 250


def test_short_or_torn_logs(tmp_path):
    assert plateau(_rows(n=10)) is None
    path = tmp_path / "metrics.jsonl"
    path.write_text("\n".join(json.dumps(r) for r in _rows(n=30)) + '\n{"step": 31, "ti')
    assert len(read_metrics(path)) == 30
