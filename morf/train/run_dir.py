"""A training run folder ``PROJECT/runs/<name>/`` as training uses it.

The folder's files, their names and the reading of the small ones belong to
:mod:`morf.train.run_files` (torch-free; its docstring shows the layout). :class:`RunDir` adds what
needs the training stack: the config as a ``TrainConfig``, and the checkpoints, read with
``torch.load(weights_only=True)``.
"""

from __future__ import annotations

import json

import torch

from morf.errors import ProjectError
from morf.io import atomic_path, atomic_write_json
from morf.io.torch_files import load_torch_file
from morf.train.config import TrainConfig
from morf.train.run_files import CONFIG_FILE, RunFiles


class RunDir(RunFiles):
    """Paths and small helpers of one run folder (:class:`RunFiles`), with its config and checkpoints."""

    # ---- config ---------------------------------------------------------------------------
    def save_config(self, cfg: TrainConfig) -> None:
        atomic_write_json(self.config_path, cfg.to_dict())

    def load_config(self) -> TrainConfig:
        try:
            return TrainConfig.from_dict(self.read_config_dict())
        except FileNotFoundError:
            raise ProjectError(f"run {self.root} has no {CONFIG_FILE}") from None
        except (json.JSONDecodeError, TypeError) as e:
            raise ProjectError(f"damaged run config {self.config_path}: {e}") from None

    # ---- checkpoints ----------------------------------------------------------------------
    def save_checkpoint(self, state: dict) -> None:
        with atomic_path(self.checkpoint_path) as tmp:
            torch.save(state, tmp)

    def load_checkpoint(self, map_location="cpu") -> dict:
        return load_torch_file(self.checkpoint_path, map_location)
