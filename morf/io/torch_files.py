"""Reading torch files a user may have been handed: ``torch.load(weights_only=True)``, one-line errors.

A file whose pickle names other objects than tensors and plain containers (a foreign checkpoint,
or one made to run code when unpickled) is refused as such. torch's own message suggests
``weights_only=False``, the one thing never to do with a file from elsewhere, so it is not passed
on. torch is imported on first use: the rest of :mod:`morf.io` stays torch-free.
"""

from __future__ import annotations

import pickle
import re
import warnings
from pathlib import Path

from morf.errors import InputError, MorfError, ProjectError


def load_torch_file(path: str | Path, map_location="cpu", *, what: str = "checkpoint",
                    use: str = "use a file written by morf train, or train again",
                    missing: type[MorfError] = ProjectError):
    """The object in ``path`` (tensors and plain containers only).

    Args:
        what: the kind of file, for messages ("VGG-16 weights"); use: what to do instead, for messages;
        missing: the error raised when the file does not exist.
    """
    import torch

    path = Path(path)
    if not path.is_file():
        raise missing(f"{what} not found: {path}")
    try:
        with warnings.catch_warnings():  # e.g. a pickle protocol torch did not write: the error says enough
            warnings.simplefilter("ignore")
            return torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as e:
        found = re.search(r"GLOBAL ([\w.]+)", str(e))
        if not found and _is_plain_pickle(path):  # pickle.dump of anything: never unpickled here
            raise InputError(f"{path} holds objects other than tensors (a plain Python pickle), so it is not loaded, "
                             f"for safety: loading them could run any code; {use}") from None
        if not found:  # no object named: not a pickle torch reads (a damaged or foreign file)
            reason = re.search(r"WeightsUnpickler error:\s*(.+)", str(e))
            raise InputError(f"cannot read {path}: it is damaged or not a PyTorch {what} "
                             f"({reason.group(1)[:120] if reason else 'unreadable pickle'}); {use}") from None
        kind = f" ({found.group(1)})"
        raise InputError(f"{path} holds objects other than tensors{kind}, so it is not loaded, for safety: loading "
                         f"them could run any code; {use}") from None
    except Exception as e:  # corrupt, truncated, or no torch file at all
        first = (str(e).strip().splitlines() or [""])[0].split(". ")[0][:160]  # torch's first sentence
        reason = f"{type(e).__name__}: {first}" if first else type(e).__name__
        raise InputError(f"cannot read {path}: it is damaged or not a PyTorch {what} ({reason}); {use}") from None


def _is_plain_pickle(path: Path) -> bool:
    """Whether the file starts as a pickle of protocol 2 or later does (torch files are zip archives)."""
    with open(path, "rb") as f:
        return f.read(1) == b"\x80"
