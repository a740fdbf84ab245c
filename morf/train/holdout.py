"""Which capture frames a run keeps out of training for ``morf eval`` (its hold-out)."""

from __future__ import annotations

from morf.errors import ProjectError

HOLDOUT_RULES = ("frame", "position")


def split_holdout(ids: list[int], k: int, by: str = "frame") -> tuple[list[int], list[int]]:
    """(training ids, held-out ids) of the usable frames ``ids`` (in order) for hold-out ``k``.

    ``by`` = "frame": the frames whose number is a multiple of ``k`` (0, K, 2K, ...) are held out,
    so the split does not move when a refit or a review drops or restores other frames: a frame
    held out stays held out, and a frame trained on is never scored as held out. "position": every
    ``k``-th of ``ids`` (positions 0, K, 2K, ...), the rule of runs made before the frame rule (their
    config.json has no ``holdout_by``); it moves whenever the usable frames change. ``k`` = 0 holds
    nothing out.
    """
    if by not in HOLDOUT_RULES:
        raise ProjectError(f"unknown hold-out rule {by!r}; choose one of {', '.join(HOLDOUT_RULES)}")
    if k <= 0:
        return list(ids), []
    if k == 1:
        raise ProjectError("a hold-out of every frame leaves nothing to train on; use K >= 2")
    held = list(ids[::k]) if by == "position" else [i for i in ids if i % k == 0]
    keep = set(held)
    return [i for i in ids if i not in keep], held


def holdout_note(k: int, by: str) -> str:
    """The line a run's log and notes give its hold-out."""
    if by == "position":
        return f"hold-out: every {k}th usable frame (positions 0, {k}, {2 * k}, ...) is kept out of training"
    return f"hold-out: the usable frames numbered 0, {k}, {2 * k}, ... (1 in {k}) are kept out of training"
