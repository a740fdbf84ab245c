"""Frame times of a capture: when each kept frame was shown in the source video.

A phone clip's frame rate varies (low light halves it, a busy encoder drops frames), so a
frame's index over the average rate can be a fraction of a second off its real time. Ingest
keeps the video's presentation times in the project manifest (``frame_times``, seconds since the
video's first frame); projects without them (images, older projects, videos decoded without
PyAV, or a ``--fps`` given by the user) use index / fps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

VARIABLE_SPREAD = 0.1  # intervals further apart than this share of the median make a rate variable


@dataclass(frozen=True)
class FrameTiming:
    """The timing ingest records.

    Fields:
        times: (N,) float64 seconds of each kept frame since the video's first frame, or None
            when the source gave no usable times.
        source: "timestamps" (the video's own), "fps" (index / frame rate) or "none".
        variable: whether the intervals between kept frames differ (variable frame rate).
        interval_ms: (min, median, max) milliseconds between kept frames, or None.
        problem: why the video's times were not used, or "".
    """

    times: np.ndarray | None
    source: str
    variable: bool = False
    interval_ms: tuple[float, float, float] | None = None
    problem: str = ""

    def record(self) -> dict:
        """The manifest's ``ingest.timing`` entry."""
        out = {"source": self.source, "variable": self.variable,
               "interval_ms": None if self.interval_ms is None else [round(v, 3) for v in self.interval_ms]}
        if self.problem:
            out["problem"] = self.problem
        return out

    def sentence(self) -> str | None:
        """What a user should hear about the timing, if anything."""
        if self.problem:
            return f"frame times not recorded: {self.problem}"
        if self.variable and self.interval_ms is not None:
            lo, med, hi = self.interval_ms
            return (f"variable frame rate: {lo:.1f} to {hi:.1f} ms between frames (median {med:.1f} ms); "
                    f"each frame's time is recorded")
        return None


def frame_timing(times: list[float | None], fps: float | None, fps_from_user: bool) -> FrameTiming:
    """Timing of the kept frames from their presentation times (``None`` entries: unknown).

    A user's ``--fps`` overrides the video's times; missing or decreasing times are not recorded.
    """
    if fps_from_user or not times or any(t is None for t in times):
        return FrameTiming(None, "fps" if fps else "none")
    t = np.asarray(times, np.float64)
    if len(t) > 1 and (np.diff(t) <= 0).any():
        return FrameTiming(None, "fps" if fps else "none", problem="the video's timestamps do not increase")
    if len(t) < 2:
        return FrameTiming(t, "timestamps")
    d = np.diff(t) * 1000.0
    lo, med, hi = float(d.min()), float(np.median(d)), float(d.max())
    return FrameTiming(t, "timestamps", hi - lo > VARIABLE_SPREAD * med, (lo, med, hi))
