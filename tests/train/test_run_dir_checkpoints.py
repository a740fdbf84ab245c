"""Checkpoints are read with ``torch.load(weights_only=True)``; a file it refuses (a foreign or
malicious pickle) or cannot read is one line that never suggests ``weights_only=False``."""

from __future__ import annotations

import os
import pickle
import warnings

import pytest
import torch

from morf.errors import InputError
from morf.train.run_dir import load_torch_file


class _RunsCode:
    """Unpickling this would run a command that leaves a marker file."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


class _Foreign:
    pass


def refused(path) -> str:
    with pytest.raises(InputError) as e:
        load_torch_file(path)
    text = str(e.value)
    assert "\n" not in text and "weights_only" not in text and "will likely succeed" not in text, text
    return text


def test_a_checkpoint_of_tensors_loads(tmp_path):
    torch.save({"step": 3, "model": {"w": torch.ones(2)}}, tmp_path / "ok.pt")
    assert load_torch_file(tmp_path / "ok.pt")["model"]["w"].sum() == 2


@pytest.mark.parametrize("how", ["torch.save", "pickle"])
def test_a_pickle_that_would_run_code_is_not_loaded(tmp_path, how):
    marker, path = tmp_path / "ran", tmp_path / "checkpoint.pt"
    payload = {"model": _RunsCode(marker)}
    if how == "torch.save":
        torch.save(payload, path)
    else:
        path.write_bytes(pickle.dumps(payload))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # torch's warning about the pickle protocol stays inside too
        text = refused(path)
    assert "holds objects other than tensors" in text and "not loaded, for safety" in text
    assert not marker.exists()


def test_a_checkpoint_with_foreign_objects_names_them(tmp_path):
    torch.save({"model": _Foreign()}, tmp_path / "foreign.pt")
    text = refused(tmp_path / "foreign.pt")
    assert "holds objects other than tensors (" in text and "_Foreign" in text


@pytest.mark.parametrize("content", [b"", b"just some notes\n", b"PK\x03\x04 cut short"])
def test_a_damaged_or_foreign_file_is_one_line(tmp_path, content):
    (tmp_path / "checkpoint.pt").write_bytes(content)
    assert "damaged or not a PyTorch checkpoint" in refused(tmp_path / "checkpoint.pt")


def test_a_truncated_checkpoint_is_one_line(tmp_path):
    torch.save({"w": torch.zeros(1000)}, tmp_path / "full.pt")
    data = (tmp_path / "full.pt").read_bytes()
    (tmp_path / "cut.pt").write_bytes(data[: len(data) // 2])
    assert "damaged or not a PyTorch checkpoint" in refused(tmp_path / "cut.pt")
