"""How far apart neighbouring frames are, so that the fit's temporal terms know what to expect.

The temporal weights were tuned on a 30 fps turn, where neighbours are 33 ms and about 2 degrees
of heading apart. Eight photos of the same turn are 45 degrees apart: pulling each towards its
neighbours as if they were 33 ms away drags the pelvis towards the neighbours' heading while the
keypoints hold the shoulders, and the fit twists the body at the waist. So each pair of neighbours
gets a gap, in reference frame intervals, from the best evidence the capture has:

* ``times``: the capture's frame times (a video's presentation times, or index / fps);
* ``heading``: no times, but an order: the heading change that the rigid first stage found
  between the two frames, where it is larger than a video frame ever turns;
* ``unordered``: views in no particular order (a photo set): no frame is another's neighbour.

A smooth motion changes about in proportion to the time between frames, so a squared difference
grows with the gap squared; dividing the temporal weight by ``gap ** 2`` keeps the same penalty on
the speed of the motion, whatever the spacing. Gaps never go below 1: the weights were set per
frame against per-frame detection noise, and a faster camera does not make a detector quieter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

REFERENCE_INTERVAL_S = 1.0 / 30.0  # the frame interval the temporal weights were tuned at
# heading change per reference frame of the capture the weights were tuned on (a full turn over
# about 190 frames); a larger change between neighbours counts as that many frames apart ...
HEADING_PER_FRAME_DEG = 2.0
# ... once it exceeds what the rigid fit's noise and a brisk turn give between video frames
HEADING_NOISE_DEG = 10.0
NEIGHBOUR_GAP = 3.0  # frames further apart than this are not neighbours for the pose-jump test
# a clip whose person turns faster than this (degrees per frame, over TURN_WINDOW frames either
# side) is smoothed as if its frames were (speed / HEADING_PER_FRAME_DEG) frames apart. The first
# stage's headings on the default synthetic capture (true turn at most 2.5 degrees a frame,
# MediaPipe keypoints) reach 4.1 over 8 frames either side (5.8 over 3): below this, so such a
# capture keeps its gaps of 1
FAST_TURN_DEG = 4.5
TURN_WINDOW = 8


@dataclass(frozen=True)
class FrameSpacing:
    """Fields:
        gaps: (N-1,) float64 distance between frame i and i+1 in reference frame intervals
            (>= 1; inf between unordered views).
        source: "times" | "heading" | "unordered" (see the module docstring).
    """

    gaps: np.ndarray
    source: str

    @property
    def unordered(self) -> bool:
        return self.source == "unordered"

    def temporal_weights(self) -> np.ndarray:
        """(N-1,) factor on each neighbour pair's temporal terms: 1 / gap^2 (0 between unordered views)."""
        return gap_weights(self.gaps)


    def switch_weights(self) -> np.ndarray:
        """(N-1,) factor on the cost of turning between neighbours when the first stage picks each
        frame's heading: 1 / gap (a turn of the same speed costs the same), 0 between unordered views."""
        return np.where(np.isfinite(self.gaps), 1.0 / np.maximum(self.gaps, 1.0), 0.0)

    def neighbours(self) -> np.ndarray:
        """(N-1,) bool: frame i and i+1 are close enough in time for a sudden pose change to be a glitch."""
        return self.gaps <= NEIGHBOUR_GAP

    def describe(self) -> str:
        """One line for a user: how far apart the fit takes the frames to be."""
        if self.unordered:
            return "frames fitted as unordered views (a photo set): no smoothing between them"
        if len(self.gaps) == 0:
            return "one frame"
        med = float(np.median(self.gaps))
        by = "frame times" if self.source == "times" else "heading change between frames"
        return (f"frames {med:.3g} video frames apart (median, from the {by}); temporal smoothing "
                f"scaled to match" if med > 1.5 else f"frames about one video frame apart (from the {by})")



def gap_weights(gaps: np.ndarray) -> np.ndarray:
    """(N-1,) 1 / gap^2 of :attr:`FrameSpacing.gaps` (gaps under 1 count as 1; 0 where infinite)."""
    gaps = np.asarray(gaps, np.float64)
    return np.where(np.isfinite(gaps), 1.0 / np.maximum(gaps, 1.0) ** 2, 0.0)

def dense(num_frames: int) -> FrameSpacing:
    """Every frame one reference interval from the next (what fitting assumed before it knew)."""
    return FrameSpacing(np.ones(max(0, num_frames - 1)), "times")


def unordered(num_frames: int) -> FrameSpacing:
    return FrameSpacing(np.full(max(0, num_frames - 1), np.inf), "unordered")


def from_times(times: np.ndarray) -> FrameSpacing:
    """Gaps from (N,) frame times in seconds."""
    dt = np.diff(np.asarray(times, np.float64))
    return FrameSpacing(np.maximum(dt / REFERENCE_INTERVAL_S, 1.0), "times")


def turn_speed_deg(root: np.ndarray, window: int = TURN_WINDOW) -> np.ndarray:
    """(N-1,) heading change per frame around each neighbour pair, degrees: the angle between the
    (N, 3, 3) root rotations ``window`` frames before and after the pair, over the frames between
    (one pair's change is the first stage's noise; a turn keeps its direction over several)."""
    N = len(root)
    if N < 2:
        return np.zeros(0)
    i = np.arange(N - 1)
    a, b = np.clip(i - window + 1, 0, N - 1), np.clip(i + window, 0, N - 1)
    rel = np.einsum("nba,nbc->nac", root[a], root[b])
    angle = np.degrees(np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    return angle / np.maximum(b - a, 1)


def with_turn_speed(spacing: FrameSpacing, root: np.ndarray) -> FrameSpacing:
    """``spacing`` (from frame times) with the pairs where the person turns faster than
    ``FAST_TURN_DEG`` a frame counted as further apart: the temporal weights were set for a turn
    of about ``HEADING_PER_FRAME_DEG`` a frame, and a brisk spin held to them lags at the turn's
    ends (25 degrees at the start of a 7.5 degree-a-frame spin). A turn at the speed the weights
    were tuned at keeps its gaps."""
    if spacing.unordered or len(spacing.gaps) == 0:
        return spacing
    speed = turn_speed_deg(root)
    fast = np.where(speed > FAST_TURN_DEG, speed / HEADING_PER_FRAME_DEG, 1.0)
    return FrameSpacing(np.maximum(spacing.gaps, fast), spacing.source)


def from_heading(root: np.ndarray) -> FrameSpacing:
    """Gaps from (N, 3, 3) root rotations of the rigid first stage, frames in capture order."""
    if len(root) < 2:
        return FrameSpacing(np.zeros(0), "heading")
    rel = np.einsum("nba,nbc->nac", root[:-1], root[1:])
    turn = np.degrees(np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    return FrameSpacing(np.where(turn > HEADING_NOISE_DEG, turn / HEADING_PER_FRAME_DEG, 1.0), "heading")
