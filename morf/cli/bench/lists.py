"""Comma-separated lists on the benchmarks' command lines (``--series a,b``, ``--points x,y``)."""

from __future__ import annotations


def comma_list(text: str | None) -> list[str] | None:
    """The non-empty names of ``text``, stripped; None for no text (the benchmark's default)."""
    return [a.strip() for a in text.split(",") if a.strip()] if text else None
