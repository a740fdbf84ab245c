"""Progress bars for long stages (tqdm on a terminal; quiet lines otherwise)."""

from __future__ import annotations

import os
import sys
from typing import Iterable, TypeVar

from tqdm import tqdm

T = TypeVar("T")


def progress(iterable: Iterable[T] | None = None, *, total: int | None = None, desc: str = "", unit: str = "it",
             disable: bool | None = None) -> tqdm:
    """A tqdm bar on stderr; disabled when ``MORF_QUIET=1``."""
    if disable is None:
        disable = bool(os.environ.get("MORF_QUIET"))
    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr, disable=disable,
                dynamic_ncols=True, mininterval=0.5, leave=False)
