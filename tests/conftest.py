"""Shared fixtures: one body model per test session, small synthetic data, shared data path."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MORF_QUIET", "1")

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


@pytest.fixture(scope="session")
def body_model():
    from morf.body import load_body_model

    return load_body_model("anny")


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the repository; tests that need it skip cleanly without it."""
    p = SHARED / "data"
    if not p.is_dir():
        pytest.skip("../shared/data is not present beside the repository")
    return p


@pytest.fixture(scope="module")
def gl():
    """A headless OpenGL (EGL) context; tests that need one skip cleanly where EGL is missing."""
    from morf.raster import GLUnavailable, gl_state

    try:
        return gl_state()
    except GLUnavailable as e:
        pytest.skip(str(e))
