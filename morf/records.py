"""Helpers for the frozen dataclasses that carry arrays from one stage to the next.

Most of them say how many items they hold (vertices, joints, frames) by the first axis of one of
their arrays; :func:`length_of` writes that property once, so each record names the array and
nothing else.
"""

from __future__ import annotations


def length_of(field: str) -> property:
    """A read-only property: the length of the first axis of the array field ``field``, as an int
    (``num_vertices = length_of("positions")`` in the class body)."""

    def length(self) -> int:
        return int(getattr(self, field).shape[0])

    length.__doc__ = f"The length of ``{field}``'s first axis."
    return property(length)
