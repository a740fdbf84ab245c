"""Progress bars for long stages (tqdm on a terminal; quiet lines otherwise)."""

from __future__ import annotations

import os
import sys
from typing import Iterable, TypeVar

from tqdm import tqdm

T = TypeVar("T")


def progress(iterable: Iterable[T] | None = None, *, total: int | None = None, desc: str = "", unit: str = "it",
             disable: bool | None = None) -> tqdm:
    """A tqdm bar on stderr when it is a terminal; disabled when ``MORF_QUIET=1`` or stderr is a
    pipe or a file (a log then holds the command's lines, not the bar's redraws)."""
    if disable is None:
        disable = bool(os.environ.get("MORF_QUIET")) or not _is_terminal(sys.stderr)
    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr, disable=disable,
                dynamic_ncols=True, mininterval=0.5, leave=False)


def _is_terminal(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
