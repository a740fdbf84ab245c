"""A training run folder ``PROJECT/runs/<name>/``.

Layout::

    config.json      the resolved TrainConfig (read back on resume)
    checkpoint.pt    latest training state (atomic; torch.save of state dicts and plain numbers)
    avatar.pt        the trained avatar for export: baked texture + renderer (written at the end)
    train.log        human-readable log lines
    metrics.jsonl    one JSON object per logged step ({"step", "time_s", losses...})

Checkpoints are read with ``torch.load(weights_only=True)``.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import torch

from morf.errors import InputError, ProjectError
from morf.io import atomic_path, atomic_write_json
from morf.train.config import TrainConfig


class RunDir:
    """Paths and small helpers of one run folder."""

    def __init__(self, root: str | Path):
        self.root = Path(root)

    config_path = property(lambda self: self.root / "config.json")
    checkpoint_path = property(lambda self: self.root / "checkpoint.pt")
    avatar_path = property(lambda self: self.root / "avatar.pt")
    log_path = property(lambda self: self.root / "train.log")
    metrics_path = property(lambda self: self.root / "metrics.jsonl")

    @property
    def has_checkpoint(self) -> bool:
        return self.checkpoint_path.is_file()

    @property
    def is_done(self) -> bool:
        return self.avatar_path.is_file()

    # ---- config ---------------------------------------------------------------------------
    def save_config(self, cfg: TrainConfig) -> None:
        atomic_write_json(self.config_path, cfg.to_dict())

    def load_config(self) -> TrainConfig:
        try:
            return TrainConfig.from_dict(json.loads(self.config_path.read_text()))
        except FileNotFoundError:
            raise ProjectError(f"run {self.root} has no config.json") from None
        except (json.JSONDecodeError, TypeError) as e:
            raise ProjectError(f"damaged run config {self.config_path}: {e}") from None

    # ---- checkpoints ----------------------------------------------------------------------
    def save_checkpoint(self, state: dict) -> None:
        with atomic_path(self.checkpoint_path) as tmp:
            torch.save(state, tmp)

    def load_checkpoint(self, map_location="cpu") -> dict:
        return load_torch_file(self.checkpoint_path, map_location)

    # ---- logging --------------------------------------------------------------------------
    def log(self, line: str) -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        with open(self.log_path, "a") as f:
            f.write(time.strftime("%Y-%m-%d %H:%M:%S ") + line + "\n")

    def append_metrics(self, record: dict) -> None:
        clean = {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in record.items()}
        with open(self.metrics_path, "a") as f:
            f.write(json.dumps(clean) + "\n")

    def read_metrics(self) -> list[dict]:
        if not self.metrics_path.is_file():
            return []
        out = []
        for line in self.metrics_path.read_text().splitlines():
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                continue  # a line cut by a kill
        return out


def load_torch_file(path: Path, map_location="cpu") -> dict:
    """``torch.load(weights_only=True)`` with one-line errors."""
    path = Path(path)
    if not path.is_file():
        raise ProjectError(f"missing file: {path}")
    try:
        return torch.load(path, map_location=map_location, weights_only=True)
    except Exception as e:  # corrupt or foreign file
        raise InputError(f"cannot read {path}: {e}") from None
