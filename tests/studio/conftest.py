"""Fixtures for the studio tests: a tiny capture project written from scratch (no other stage
needed), a tiny exported avatar, and the headless studio itself."""

from __future__ import annotations

import importlib
import json
import os

import numpy as np
import pytest

from morf.capture.project import CaptureProject, Keypoints2D
from morf.capture.keypoint_layout import NUM_KEYPOINTS
from morf.fitting.fits_io import BodyFits, save_fits
from morf.io import write_image
from screenshots import WINDOW
from tests.conftest import require

FRAMES, WIDTH, HEIGHT = 6, 96, 128
REQUIRE_GL_ENV = "MORF_REQUIRE_GL"  # "1": no headless OpenGL fails the studio tests instead of skipping them
# what the studio shows for the library's stages when a test gives it none
NOT_IN_THIS_BUILD = {"fit": "morf.fitting is not part of this build", "train": "morf.train is not part of this build",
                     "export": "morf.export is not part of this build"}


def _stick_figure(i: int) -> np.ndarray:
    """(23, 2) keypoints of a person turning a little with ``i``."""
    cx, s = WIDTH / 2 + 3 * np.sin(i), 1.0 + 0.05 * i
    pts = {
        0: (0, 18), 1: (-3, 15), 2: (3, 15), 3: (-6, 17), 4: (6, 17),
        5: (-14, 32), 6: (14, 32), 7: (-20, 50), 8: (20, 50), 9: (-22, 66), 10: (22, 66),
        11: (-9, 68), 12: (9, 68), 13: (-10, 92), 14: (10, 92), 15: (-10, 114), 16: (10, 114),
        17: (-14, 120), 18: (-16, 119), 19: (-9, 117), 20: (14, 120), 21: (16, 119), 22: (9, 117),
    }
    out = np.zeros((NUM_KEYPOINTS, 2), np.float32)
    for k, (dx, y) in pts.items():
        out[k] = (cx + s * dx, y)
    return out


def _placeholder_fits(residuals: np.ndarray) -> BodyFits:
    """Body fits whose only meaningful field is the per-frame keypoint residual (the studio shows no more)."""
    n = len(residuals)
    zeros = np.zeros(n, np.float32)
    return BodyFits(rotvecs=np.zeros((n, 1, 3), np.float32), transl=np.zeros((n, 3), np.float32),
                    shape=np.full((1, 1), 0.5, np.float32), keypoint_residual_px=residuals, keypoint_worst_px=residuals,
                    silhouette_iou=zeros, projected_keypoints=np.zeros((n, NUM_KEYPOINTS, 2), np.float32),
                    config={})


def make_tiny_project(root, *, with_fit: bool = True) -> CaptureProject:
    """6 frames of 96x128: a coloured backdrop, a figure, its mask and keypoints; frame 4 has no person."""
    project = CaptureProject.create(root, num_frames=FRAMES, width=WIDTH, height=HEIGHT, fps=10.0,
                                    source={"kind": "test"})
    points = np.zeros((FRAMES, NUM_KEYPOINTS, 3), np.float32)
    detected = np.ones(FRAMES, bool)
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    for i in range(FRAMES):
        kp = _stick_figure(i)
        img = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
        img[..., 0] = 40 + 30 * i
        img[..., 1] = (yy * 120 // HEIGHT).astype(np.uint8)
        img[..., 2] = 90
        mask = (np.abs(xx - kp[11:13, 0].mean()) < 14) & (yy > 10) & (yy < 120)
        if i == 4:
            mask[:] = False
            detected[i] = False
        else:
            img[mask] = (220, 190, 160)
            points[i, :, :2] = kp
            points[i, :, 2] = 0.9
        project.save_frame(i, img)
        project.save_mask(i, mask)
    project.save_keypoints(Keypoints2D(points, detected, np.array(["test"] * FRAMES)))
    if with_fit:  # what 'morf fit' leaves behind: the filter's verdicts, residuals, overlay images
        fits = root / "fits"
        (fits / "overlays").mkdir(parents=True)
        (fits / "filter.json").write_text(json.dumps({"rejected": {"1": "keypoint residual 41 px (median 5)"},
                                                      "frames": FRAMES}))
        residuals = np.array([3.0 + i if i != 4 else np.nan for i in range(FRAMES)], np.float32)
        save_fits(project.fits_path, _placeholder_fits(residuals))
        for i in range(FRAMES):
            overlay = project.load_frame(i)
            overlay[20:118, 36:60] = (80, 140, 255)  # a "fitted body" the colour of the real overlays
            write_image(fits / "overlays" / f"{i:06d}.jpg", overlay)
    return project


@pytest.fixture(autouse=True)
def studio_settings(tmp_path_factory, monkeypatch):
    """The studio's settings file (recent motion folders) in a temporary folder, never the user's."""
    path = tmp_path_factory.mktemp("settings") / "studio.json"
    monkeypatch.setenv("MORF_STUDIO_SETTINGS", str(path))
    return path


@pytest.fixture
def tiny_project(tmp_path) -> CaptureProject:
    return make_tiny_project(tmp_path / "capture")


@pytest.fixture(scope="session")
def tiny_avatar_dir(tmp_path_factory, body_model):
    """A tiny exported avatar: a renderer whose mask is the body's coverage + a spectral texture."""
    from types import SimpleNamespace

    from morf.export.synthetic import build_synthetic_avatar, coverage_renderer, coverage_texture

    out = tmp_path_factory.mktemp("avatar") / "avatar"
    build_synthetic_avatar(out, body_model, renderer=coverage_renderer(), texture=coverage_texture(),
                           renderer_cfg=SimpleNamespace(in_channels=16), image_size=64,
                           calibration_views=4, heldout_views=1, seed=3)
    return out


@pytest.fixture
def make_app(tmp_path, monkeypatch):
    """``make_app(project=None, **kw)``: a headless studio, closed at the end of the test.

    The working folder is tmp_path (relative paths keep screenshots free of temporary folder
    names); ``tiny_project`` is "capture" there. ``kw`` goes to StudioApp, by default: the window
    size of the goldens, no stages (``stages=None``: the library's) listed as not part of this
    build, and the empty motion folder "motions". Skips where there is no headless OpenGL
    (:class:`GLUnavailable`; any other error fails the test), fails there too under
    ``MORF_REQUIRE_GL=1`` (CI on a machine with EGL: the studio tests must run, not skip).
    """
    if os.environ.get(REQUIRE_GL_ENV) == "1":
        importlib.import_module("imgui_bundle")  # required: the studio tests must run, not skip
    else:
        require("imgui_bundle")
    from morf.raster.gl_context import GLUnavailable
    from studio.app import StudioApp

    monkeypatch.chdir(tmp_path)
    (tmp_path / "motions").mkdir()
    apps = []

    def make(project=None, **kw):
        kw = {"size": WINDOW, "stages": {}, "unavailable": NOT_IN_THIS_BUILD, "motion_dir": "motions", **kw}
        try:
            app = StudioApp(project, headless=True, **kw)
        except GLUnavailable as e:
            if os.environ.get(REQUIRE_GL_ENV) == "1":
                pytest.fail(f"{REQUIRE_GL_ENV}=1 but there is no headless OpenGL here: {e}")
            pytest.skip(f"no headless OpenGL here: {e}")
        apps.append(app)
        return app

    yield make
    for app in apps:
        app.close()
