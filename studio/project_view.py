"""The open project as the UI sees it: sizes, keypoints, frame decisions and fit residuals.

Loaded once when a project opens (small files only: the manifest, keypoints.npz, review.json and
fits/filter.json); images are decoded later by :mod:`studio.loader`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from morf.capture.project import CaptureProject, FrameDecision, Keypoints2D
from morf.errors import ProjectError
from studio.run_list import RunSummary, read_runs


class ProjectView:
    """Read-only facts about one project; :meth:`reload_decisions` after the worker changed review.json.

    Attributes:
        project: the :class:`CaptureProject`.
        keypoints: :class:`Keypoints2D` with points (N, 23, 3), or None when keypoints.npz is absent.
        decisions: per frame :class:`FrameDecision` (user choices override the automatic filter).
        residuals: frame -> mean keypoint residual of the body fit in pixels (empty before fitting).
    """

    runs: list[RunSummary]  # the training runs on disk, newest first

    def __init__(self, project: CaptureProject):
        self.project = project
        kp_path = project.root / "keypoints.npz"
        self.keypoints: Keypoints2D | None = project.load_keypoints() if kp_path.is_file() else None
        self.refresh()

    def refresh(self) -> None:
        """Re-read what stages write (decisions, residuals, overlays, avatar), e.g. after a stage ended."""
        self.decisions: list[FrameDecision] = self.project.frame_decisions()
        self.residuals: dict[int, float] = _load_residuals(self.project)
        self._fit_overlays = (self.project.fits_dir / "overlays").is_dir()
        d = self.project.avatar_dir
        self._avatar_ready = d.is_dir() and any(d.iterdir())
        self.runs: list[RunSummary] = read_runs(self.project.root)

    @classmethod
    def open(cls, root: str | Path) -> "ProjectView":
        """Open a project folder; raises :class:`ProjectError` with a one-line reason."""
        return cls(CaptureProject.open(root))

    @property
    def root(self) -> Path:
        return self.project.root

    @property
    def num_frames(self) -> int:
        return self.project.num_frames

    @property
    def name(self) -> str:
        return self.project.root.name

    def reload_decisions(self) -> None:
        self.decisions = self.project.frame_decisions()

    def flagged(self, i: int) -> bool:
        """A frame the user should look at: not used for training."""
        return 0 <= i < len(self.decisions) and not self.decisions[i].used

    def next_flagged(self, after: int) -> int | None:
        """The next flagged frame after ``after`` (wrapping around), or None when none is flagged."""
        n = self.num_frames
        for k in range(1, n + 1):
            if self.flagged((after + k) % n):
                return (after + k) % n
        return None

    def user_dropped(self, i: int) -> bool:
        return 0 <= i < len(self.decisions) and self.decisions[i].reason == "dropped by user"

    def fit_overlay_path(self, i: int) -> Path:
        """The fit's overlay image of frame i (fits/overlays/000000.jpg, written by ``morf fit``)."""
        base = self.project.fits_dir / "overlays" / f"{i:06d}"
        png = base.with_suffix(".png")
        return png if png.is_file() else base.with_suffix(".jpg")

    def has_fit_overlays(self) -> bool:
        return self._fit_overlays

    def avatar_ready(self) -> bool:
        return self._avatar_ready

    def keypoints_of(self, i: int) -> np.ndarray | None:
        """(23, 3) x, y, confidence of frame i, or None without keypoints or detection."""
        if self.keypoints is None or not self.keypoints.detected[i]:
            return None
        return self.keypoints.points[i]


def _load_residuals(project: CaptureProject) -> dict[int, float]:
    """Per-frame mean keypoint residual of the body fit (``project.fits_path``), empty before fitting."""
    if not project.fits_path.is_file():
        return {}
    # imported here: the app needs the fits reader only once a project has fits
    from morf.fitting.fits_io import load_fits

    fits = load_fits(project)
    r = fits.keypoint_residual_px
    if r.shape != (fits.num_frames,):
        raise ProjectError(f"damaged fits file {project.fits_path}: keypoint_residual_px is not per frame")
    return {i: float(v) for i, v in enumerate(r) if np.isfinite(v)}
