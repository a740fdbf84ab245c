"""PNG charts of the sweep and the stress series (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path, title: str | None = None) -> Path:
    """Write ``fig`` to ``path`` (its folder made) and close it, so a long benchmark holds no
    figures; ``title``: a title over all panels, laid out before saving."""
    plt = _pyplot()
    if title is not None:
        fig.suptitle(title, fontsize=10)
        fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def front_chart(points: list[dict], x: str, y: str, front: np.ndarray, path: Path, *, title: str, xlabel: str,
                ylabel: str, log_x: bool = False, target_x: float | None = None, target_label: str = "",
                note: str = "", spread: tuple[float, float, float] | None = None,
                reference_y: float | None = None, reference_label: str = "") -> Path:
    """Scatter of ``points[i][x]`` against ``points[i][y]`` with the Pareto front drawn as a step line.

    Args:
        front: (N,) bool, points on the front (from :func:`morf.bench.front.pareto_front`).
        target_x: draws a vertical line there (e.g. the paper's 30 fps), labelled ``target_label``.
        note: a footnote under the axes (what is comparable with the paper and what is not).
        spread: (x, low, high): the base point's range over training seeds, drawn as a bar at x.
        reference_y: a quality with no speed on this axis (the RGB floor), drawn as a horizontal
            line labelled ``reference_label``.
    A point trained with several seeds (``p["seed_runs"][y]``, its ``y`` then their mean) gets the
    range of its runs as a grey bar.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    xs = np.array([p.get(x) if p.get(x) is not None else np.nan for p in points], float)
    ys = np.array([p.get(y) if p.get(y) is not None else np.nan for p in points], float)
    ok = np.isfinite(xs) & np.isfinite(ys)
    ax.scatter(xs[ok & ~front], ys[ok & ~front], c="tab:gray", s=30, label="sweep point")
    ax.scatter(xs[front], ys[front], c="tab:red", s=45, label="Pareto front", zorder=3)
    order = np.argsort(xs[front])
    ax.plot(xs[front][order], ys[front][order], c="tab:red", lw=1, alpha=0.7, drawstyle="steps-mid")
    for (p, xv, yv), dy in zip([(p, xv, yv) for p, xv, yv, k in zip(points, xs, ys, ok) if k],
                               _label_offsets(xs[ok], ys[ok])):
        ax.annotate(p["name"], (xv, yv), fontsize=7, xytext=(3, dy), textcoords="offset points")
    ranged = False
    for p, xv in zip(points, xs):
        runs = [v for v in (p.get("seed_runs") or {}).get(y) or [] if v is not None]
        if len(runs) > 1 and np.isfinite(xv):
            ax.vlines(xv, min(runs), max(runs), colors="tab:gray", lw=1.5, alpha=0.5, zorder=1,
                      label=None if ranged else "range over the seeds")
            ranged = True
    if spread is not None and all(v is not None and np.isfinite(v) for v in spread):
        ax.vlines(spread[0], spread[1], spread[2], colors="tab:orange", lw=3, alpha=0.6, zorder=2,
                  label="base over training seeds")
    if reference_y is not None and np.isfinite(reference_y):
        ax.axhline(reference_y, c="tab:green", ls=":", lw=1.5, label=reference_label)
    if target_x is not None:
        ax.axvline(target_x, c="tab:blue", ls="--", lw=1)
        ax.text(target_x, ax.get_ylim()[0], " " + target_label, color="tab:blue", fontsize=8, rotation=90,
                va="bottom", ha="right")
    if log_x:
        ax.set_xscale("log")
    ax.set(title=title, xlabel=xlabel, ylabel=ylabel)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    if note:
        fig.text(0.01, 0.01, note, fontsize=7, wrap=True, va="bottom")
        fig.subplots_adjust(bottom=0.2)
    return save_figure(fig, path)


def series_chart(series: dict[str, dict], metric: str, path: Path, *, title: str, ylabel: str) -> Path:
    """One panel per stress series: ``metric`` against the nuisance level, one line per method.

    Args:
        series: {series name: {"levels": [..], "label": str, "methods": {method: [row per level]}}},
            each row a dict holding ``metric`` and ``diverged`` (and, for repeated trainings,
            ``<metric>_min`` / ``_max``, drawn as a bar); diverged levels are drawn as crosses at the
            bottom of the panel.
    """
    plt = _pyplot()
    names = list(series)
    cols = min(3, max(1, len(names)))
    rows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.3 * rows), dpi=100, squeeze=False)
    colours = {"morf": "tab:red", "stylepeople": "tab:blue", "anr": "tab:green"}
    for ax, name in zip(axes.ravel(), names):
        s = series[name]
        lv = np.asarray(s["levels"], float)
        for method, rows_ in s["methods"].items():
            v = np.array([r.get(metric) if r.get(metric) is not None else np.nan for r in rows_], float)
            ax.plot(lv[:len(v)], v, "o-", c=colours.get(method), label=method, ms=4)
            lo = np.array([r.get(f"{metric}_min", np.nan) for r in rows_], float)
            hi = np.array([r.get(f"{metric}_max", np.nan) for r in rows_], float)
            if np.isfinite(lo).any():  # repeated trainings: their range
                ax.vlines(lv[:len(v)], lo, hi, colors=colours.get(method), alpha=0.5, lw=2)
            div = np.array([bool(r.get("diverged")) for r in rows_])
            if div.any():
                ax.plot(lv[:len(v)][div], np.full(div.sum(), np.nanmin(v) if np.isfinite(v).any() else 0), "x",
                        c=colours.get(method), ms=9, mew=2)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel(s.get("label", "level"), fontsize=8)
        ax.set_ylabel(ylabel, fontsize=8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    axes.ravel()[0].legend(fontsize=7)
    return save_figure(fig, path, title)


def _label_offsets(xs, ys, near: float = 0.06, step: float = 9.0) -> list[float]:
    """Vertical label offsets in points: a label whose point lies within ``near`` (share of the
    axis ranges) of earlier labelled points is moved down a line per such neighbour."""
    xs, ys = np.asarray(xs, float), np.asarray(ys, float)
    if not len(xs):
        return []
    nx = (xs - xs.min()) / max(np.ptp(xs), 1e-12)
    ny = (ys - ys.min()) / max(np.ptp(ys), 1e-12)
    out = []
    for i in range(len(xs)):
        crowd = int(np.sum(np.hypot(nx[:i] - nx[i], ny[:i] - ny[i]) < near))
        out.append(3.0 - step * crowd)
    return out
