"""The fit's last step where the project has face and hand landmarks: the head, the wrists and the
fingers turned to them (:func:`morf.fitting.head_hands.fit_head_hands`), every other bone as the
stages left it.

It runs on finished parameters, in :func:`morf.fitting.fit.finalize`, so a fit resumed from its
last checkpoint, or one finalized again, refines the same way (the refinement is deterministic).
Frames whose keypoint labels the first stage exchanged (a back view a detector took for a front
view, :mod:`morf.fitting.heading`) have their hands and the face's sides exchanged as well.
"""

from __future__ import annotations

import numpy as np

from morf.fitting.frame_spacing import gap_weights
from morf.fitting.head_hands import HeadHandsConfig, fit_head_hands
from morf.fitting.heading import exchange_labels

SMOOTH_GAP = 1.5  # frames at most this many reference intervals apart are smoothed together
# landmark_targets' order: 5 face anchors (right eye, left eye, nose tip, mouth, chin), 2 ears
# (left, right), the left hand's 21 points, the right hand's 21
_MIRROR = np.r_[[1, 0, 2, 3, 4, 6, 5], np.arange(28, 49), np.arange(7, 28)]


def exchange_landmark_labels(targets: np.ndarray, swapped: np.ndarray | None) -> np.ndarray:
    """(N, 49, 3) landmark targets with left and right exchanged where ``swapped`` (N,) is set."""
    return exchange_labels(targets, swapped, _MIRROR)


def smooth_changes(before: np.ndarray, after: np.ndarray, gaps: np.ndarray | None, passes: int = 8) -> np.ndarray:
    """``after`` (N, J, 3) with its change from ``before`` smoothed over video neighbours: a
    [1, 2, 1] / 4 kernel ``passes`` times across the pairs whose ``gaps`` (N-1,) are at most
    ``SMOOTH_GAP`` frames (none between unordered views or with ``gaps`` None).

    The refinement fits each frame on its own; a detector's landmarks wobble from frame to frame
    and the head and fingers would wobble with them (on the default capture the whole mesh's
    jitter rose from 16.3 to 20 mm / frame^2 without this; 16.5 after 2 passes, 16.4 after 4,
    16.3 after 8, where the wrists' error was lowest too: 12.4, 12.0, 11.5 degrees). Eight
    passes spread a change over about two frames either side (a Gaussian of that deviation).
    The changes are small rotations, so their axis-angles are averaged directly."""
    if gaps is None or len(before) < 3:
        return after
    link = (np.asarray(gaps) <= SMOOTH_GAP).astype(np.float64)[:, None, None]  # (N-1, 1, 1)
    d = (after - before).astype(np.float64)
    for _ in range(passes):
        left = np.concatenate([d[:1], d[:-1]]) * np.concatenate([np.zeros((1, 1, 1)), link])
        right = np.concatenate([d[1:], d[-1:]]) * np.concatenate([link, np.zeros((1, 1, 1))])
        wl = np.concatenate([np.zeros((1, 1, 1)), link])
        wr = np.concatenate([link, np.zeros((1, 1, 1))])
        d = (2 * d + left + right) / (2 + wl + wr)
    return (before + d).astype(after.dtype)


def refine_head_hands(model, rotvecs: np.ndarray, transl: np.ndarray, shape: np.ndarray, camera,
                      targets: np.ndarray, swapped: np.ndarray | None, gaps: np.ndarray | None = None,
                      cfg: HeadHandsConfig = HeadHandsConfig()) -> tuple[np.ndarray, np.ndarray]:
    """(rotvecs (N, J, 3) with the head, wrists and fingers refined, (N, 3) landmark residual in
    pixels after it: face anchors, left hand, right hand; NaN where a group has too little evidence).
    ``gaps`` (N-1,): how far apart the frames are (:class:`~morf.fitting.frame_spacing.FrameSpacing`),
    for the tie between neighbours' changes (``cfg.temporal``) and :func:`smooth_changes`."""
    pairs = None if gaps is None else gap_weights(gaps)
    res = fit_head_hands(model, rotvecs, transl, shape, camera, exchange_landmark_labels(targets, swapped), cfg, pairs)
    return smooth_changes(np.asarray(rotvecs), res.rotvecs, gaps), res.residual_after
