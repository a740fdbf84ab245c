"""Raster tests need a headless OpenGL context; they skip cleanly where EGL is missing."""

import pytest


@pytest.fixture(scope="module")
def gl():
    from morf.raster import GLUnavailable, gl_state

    try:
        return gl_state()
    except GLUnavailable as e:
        pytest.skip(str(e))
