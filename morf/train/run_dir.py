"""A training run folder ``PROJECT/runs/<name>/`` as training uses it.

The folder's files, their names and the reading of the small ones belong to
:mod:`morf.train.run_files` (torch-free; its docstring shows the layout). :class:`RunDir` adds what
needs the training stack: the config as a ``TrainConfig``, and the checkpoints, read with
``torch.load(weights_only=True)``.
"""

from __future__ import annotations

import json
import pickle
import re
import warnings
from pathlib import Path

import torch

from morf.errors import InputError, ProjectError
from morf.io import atomic_path, atomic_write_json
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


def load_torch_file(path: Path, map_location="cpu") -> dict:
    """``torch.load(weights_only=True)`` with one-line errors.

    A file whose pickle names other objects than tensors and plain containers (a foreign
    checkpoint, or one made to run code when unpickled) is refused as such. torch's own message
    suggests ``weights_only=False``, the one thing never to do with a file from elsewhere, so it is
    not passed on."""
    path = Path(path)
    if not path.is_file():
        raise ProjectError(f"missing file: {path}")
    try:
        with warnings.catch_warnings():  # e.g. a pickle protocol torch did not write: the error says enough
            warnings.simplefilter("ignore")
            return torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as e:
        found = re.search(r"GLOBAL ([\w.]+)", str(e))
        what = f" ({found.group(1)})" if found else ""
        raise InputError(f"{path} holds objects other than tensors{what}, so it is not loaded, for safety: loading "
                         f"them could run any code; use a file written by morf train") from None
    except Exception as e:  # corrupt, truncated, or no checkpoint at all
        first = (str(e).strip().splitlines() or [""])[0].split(". ")[0][:160]  # torch's first sentence
        reason = f"{type(e).__name__}: {first}" if first else type(e).__name__
        raise InputError(f"cannot read {path}: it is damaged or not a PyTorch checkpoint ({reason}); "
                         f"use a file written by morf train, or train again") from None
