"""Published train/test splits as frame ranges, and the choice of frames to import."""

from __future__ import annotations

from morf.errors import InputError

SPLIT_CHOICES = ("train", "test", "all")


def split_range(spec: tuple[int, int, int], n: int) -> list[int]:
    """(start, end, skip) with an inclusive end (InstantAvatar's convention) -> indices below n."""
    start, end, skip = spec
    return list(range(start, min(end, n - 1) + 1, skip))


def select_frames(definition: dict | None, split: str, n: int, every: int, max_frames: int | None,
                  what: str) -> tuple[list[int], list[str]]:
    """Source frame indices to import and their split labels.

    Args:
        definition: {"train": (start, end, skip), "test": (...)} or None when none is published.
        split: "train" | "test" | "all". "all" takes every frame and labels each "train",
            "test" (train wins where the two overlap) or "" (in neither).
        n: frames available; every: keep every k-th of the chosen frames; max_frames: cap.
    """
    if split not in SPLIT_CHOICES:
        raise InputError(f"--split must be one of {', '.join(SPLIT_CHOICES)}, got {split!r}")
    if every < 1:
        raise InputError(f"--every must be at least 1, got {every}")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"--max-frames must be at least 1, got {max_frames}")
    if split != "all" and definition is None:
        raise InputError(f"{what} has no published train/test split; use --split all")
    if split == "all":
        train = set(split_range(definition["train"], n)) if definition else set()
        test = set(split_range(definition["test"], n)) if definition else set()
        idx = list(range(n))
        labels = ["train" if i in train else "test" if i in test else "" for i in idx]
    else:
        idx = split_range(definition[split], n)
        labels = [split] * len(idx)
    idx, labels = idx[::every], labels[::every]
    if max_frames is not None:
        idx, labels = idx[:max_frames], labels[:max_frames]
    if not idx:
        raise InputError(f"{what}: the {split} split has no frames among the {n} available")
    return idx, labels
