"""What ``morf eval`` scores a run on (its targets):

* ``holdout-k<K>``: the capture frames a run with ``holdout`` = K kept out of training
  (:func:`morf.train.holdout.split_holdout` of the usable frames: those numbered 0, K, 2K, ...), in
  their fitted poses. Only runs trained with that K are scored on it: for the others they were
  training frames. Runs made before that rule held out every K-th usable frame instead
  (``holdout_by`` "position"); theirs is the target ``holdout-k<K>-positions``.
* ``novel-poses``: a synthetic capture's hold-out sequence (``ground_truth/holdout``), poses the
  capture never showed; every run is scored on it.
* ``test-split``: frames an imported dataset labels "test" (``morf dataset ... --split all``
  keeps the labels in the manifest), in their fitted poses, for projects that label both train
  and test frames. Those frames are training frames too unless a run's hold-out left them out
  (nothing else excludes them); each score says how many of them its run trained on.
* ``seen-k<K>`` (``morf eval --seen``): for each held-out frame of ``holdout-k<K>``, the nearest
  frame runs with that K trained on (:func:`nearest_seen`). Beside the hold-out it splits a run's
  error in two: what it cannot reproduce of frames it saw (its capacity, its training) and what it
  loses on frames it did not (the fit's error there, the poses between).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.synth.ground_truth import has_holdout, load_holdout
from morf.train.data import BodyFitArrays, published_test_frames, usable_frame_ids
from morf.train.holdout import split_holdout


@dataclass(frozen=True)
class EvalTarget:
    """A set of frames to score runs on.

    Fields:
        key: "holdout-k<K>" | "novel-poses" | "test-split" (file names and eval.json keys);
        title: a human description; kind: "capture" (project frames posed by the fits) or
        "novel-poses"; frame_ids: project frame numbers (capture) or hold-out sequence indices;
        holdout: the K whose runs it scores (capture hold-out), else None (every run);
        holdout_by: the hold-out rule of the runs it scores (see :func:`split_holdout`).
    """

    key: str
    title: str
    kind: str
    frame_ids: tuple[int, ...]
    holdout: int | None = None
    holdout_by: str = "frame"

    def applies_to(self, holdout: int, holdout_by: str = "frame") -> bool:
        return self.holdout is None or (self.holdout == holdout and self.holdout_by == holdout_by)


def split_suffix(by: str) -> str:
    """What a target's key adds for runs of the older hold-out rule ("" for the frame rule)."""
    return "" if by == "frame" else f"-{by}s"


def holdout_target(project, fits: BodyFitArrays, k: int, by: str = "frame") -> EvalTarget | None:
    """The frames runs with hold-out ``k`` (rule ``by``) kept out of training (None for k = 0 or none left)."""
    if k <= 0:
        return None
    held = split_holdout(usable_frame_ids(project, fits), k, by)[1]
    if not held:
        return None
    title = (f"held-out capture frames (numbers 0, {k}, {2 * k}, ...)" if by == "frame" else
             f"held-out capture frames (every {ordinal(k)} usable frame from the first)")
    return EvalTarget(f"holdout-k{k}{split_suffix(by)}", title, "capture", tuple(held), k, by)


def ordinal(k: int) -> str:
    """2 -> "2nd", 3 -> "3rd", 11 -> "11th"."""
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def novel_poses_target(project) -> EvalTarget | None:
    """A synthetic capture's hold-out sequence, when it has one."""
    if not has_holdout(project):
        return None
    n = load_holdout(project).num_frames
    if n == 0:
        return None
    return EvalTarget("novel-poses", "synthetic hold-out sequence (novel poses)", "novel-poses", tuple(range(n)))


def dataset_split_labels(project) -> list[str] | None:
    """Per project frame, its dataset split label, when the project was imported with both
    "train" and "test" labels; else None."""
    labels = (project.manifest.get("dataset") or {}).get("splits")
    if not isinstance(labels, list) or len(labels) != project.num_frames:
        return None
    return labels if {"train", "test"} <= set(labels) else None


def dataset_test_target(project, fits: BodyFitArrays) -> EvalTarget | None:
    """The usable frames labelled "test" by the dataset's published split."""
    labels = dataset_split_labels(project)
    if labels is None:
        return None
    ids = [i for i in usable_frame_ids(project, fits) if labels[i] == "test"]
    if not ids:
        return None
    return EvalTarget("test-split", "frames the dataset's published split labels test", "capture", tuple(ids))


def trained_frames(project, fits: BodyFitArrays, holdout: int, by: str = "frame") -> set[int]:
    """The frames a run with this hold-out setting trained on."""
    return set(split_holdout(usable_frame_ids(project, fits), holdout, by)[0]) - published_test_frames(project)


def trained_on(project, fits: BodyFitArrays, holdout: int, ids, by: str = "frame") -> int:
    """How many of ``ids`` a run with this hold-out setting trained on."""
    train = trained_frames(project, fits, holdout, by)
    return sum(1 for i in ids if i in train)


def nearest_seen(project, fits: BodyFitArrays, k: int, ids, by: str = "frame") -> tuple[int, ...]:
    """Per frame of ``ids``, the nearest frame (by frame number; a tie: the later one) that runs
    with hold-out ``k`` (rule ``by``) trained on; () when they trained on none."""
    train = np.asarray(sorted(trained_frames(project, fits, k, by)), np.int64)
    if train.size == 0:
        return ()
    out = []
    for i in ids:
        d = np.abs(train - int(i))
        out.append(int(train[np.flatnonzero(d == d.min())[-1]]))
    return tuple(out)


def seen_target(project, fits: BodyFitArrays, k: int, by: str = "frame") -> EvalTarget | None:
    """The training frames nearest the hold-out ``k``'s frames (None where there is no hold-out)."""
    held = holdout_target(project, fits, k, by)
    if held is None:
        return None
    ids = tuple(sorted(set(nearest_seen(project, fits, k, held.frame_ids, by))))
    if not ids:
        return None
    return EvalTarget(f"seen-k{k}{split_suffix(by)}", f"training frames next to the held-out ones (hold-out {k})",
                      "capture", ids, k, by)
