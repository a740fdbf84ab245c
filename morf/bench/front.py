"""Pareto fronts: the points no other point beats on every objective at once."""

from __future__ import annotations

import numpy as np


def pareto_front(values, maximize=(True, True)) -> np.ndarray:
    """Mask of non-dominated points.

    Args:
        values: (N, K) objective values per point (NaN or None marks a point with no result).
        maximize: K flags, True where larger is better.
    Returns:
        (N,) bool, True for points on the front. A point is dominated when another is at least
        as good on every objective and strictly better on one; exact ties all stay on the front.
        Points with a missing value are never on it.
    """
    v = np.asarray(values, dtype=np.float64).reshape(len(values), -1)
    sign = np.where(np.asarray(maximize, bool), 1.0, -1.0)
    v = v * sign[None, :]  # now larger is better everywhere
    ok = np.isfinite(v).all(1)
    front = np.zeros(len(v), bool)
    for i in np.flatnonzero(ok):
        others = v[ok]
        dominated = np.any(np.all(others >= v[i], 1) & np.any(others > v[i], 1))
        front[i] = not dominated
    return front


def near_front(values, index: int, margin: tuple[float, ...], maximize=(True, True)) -> bool:
    """Whether point ``index`` is within ``margin`` of the front: no other point beats it by more
    than ``margin`` on one objective while being at least as good, within ``margin``, on all the
    others (what the margin cannot tell apart counts as equal both ways).

    ``margin`` is per objective, in that objective's units (e.g. 0.5 dB of PSNR, 0 fps).
    """
    v = np.asarray(values, dtype=np.float64).reshape(len(values), -1)
    sign = np.where(np.asarray(maximize, bool), 1.0, -1.0)
    v = v * sign[None, :]
    m = np.asarray(margin, np.float64)
    if not np.isfinite(v[index]).all():
        return False
    for j in range(len(v)):
        if j == index or not np.isfinite(v[j]).all():
            continue
        if np.all(v[j] >= v[index] - m) and np.any(v[j] > v[index] + m):
            return False
    return True


def quality_gap(runs: dict[str, list], fps: dict[str, float | None], name: str,
                fps_margin: float) -> tuple[float | None, float | None, str | None]:
    """How far point ``name`` trails the best point at most ``fps_margin`` slower than it.

    ``runs``: {point: its quality per training (None: diverged)}; ``fps``: {point: mean fps}.
    Returns (gap of the means, its standard error, that point's name); the standard error is
    sqrt(s_a^2 / n_a + s_b^2 / n_b) over the trainings, None unless both points have two or more,
    and the gap is None when no other point qualifies. A verdict at margin ``m`` is beyond the
    training noise when ``|gap - m|`` exceeds about two standard errors.
    """
    def stats(name):  # (mean, squared standard error of the mean) over the finished trainings
        q = np.asarray([x for x in runs[name] if x is not None], np.float64)
        if not len(q):
            return None, None
        return float(q.mean()), (float(q.var(ddof=1)) / len(q) if len(q) > 1 else None)

    q_self, v_self = stats(name)
    if q_self is None or fps.get(name) is None:
        return None, None, None
    best = None
    for other in runs:
        q, v = stats(other)
        if other == name or q is None or fps.get(other) is None or fps[other] < fps[name] - fps_margin:
            continue
        if best is None or q > best[0]:
            best = (q, v, other)
    if best is None:
        return None, None, None
    se = (best[1] + v_self) ** 0.5 if best[1] is not None and v_self is not None else None
    return best[0] - q_self, se, best[2]
