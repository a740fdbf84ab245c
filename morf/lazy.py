"""Package attributes imported from their submodules on first use (PEP 562 module ``__getattr__``),
so that a light submodule of a package can be imported without the package's heavy ones:

    __getattr__, __dir__ = lazy_attributes(__name__, {"fit_project": "morf.fitting.project_fit", ...})
"""

from __future__ import annotations

import importlib
import sys
from typing import Callable


def lazy_attributes(package: str, where: dict[str, str]) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package``: name ``n`` is ``where[n]``'s attribute ``n``,
    imported when first asked for and then kept in the package like an ordinary import."""
    def __getattr__(name: str):
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)  # later look-ups skip this function
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(where))

    return __getattr__, __dir__
