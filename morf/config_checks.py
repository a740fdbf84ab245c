"""The checks every stage config shares: keys read from a file must be fields, and the first
setting that makes no sense is reported as one :class:`~morf.errors.InputError`."""

from __future__ import annotations

import dataclasses

from morf.errors import InputError


def check_keys(cls: type, d: dict, what: str) -> dict:
    """``d`` when all its keys are fields of dataclass ``cls``; else an InputError naming the others."""
    unknown = set(d) - {f.name for f in dataclasses.fields(cls)}
    if unknown:
        raise InputError(f"unknown {what} keys: {sorted(unknown)}")
    return d


def raise_first(checks: list[tuple[bool, str]]) -> None:
    """Raise an InputError with the message of the first ``(ok, message)`` that is not ok."""
    for ok, message in checks:
        if not ok:
            raise InputError(message)
