"""Benchmark tests run the tiny presets end to end; they need OpenGL (EGL) and skip without it."""

import pytest


@pytest.fixture(scope="module")
def gl():
    from morf.raster import GLUnavailable, gl_state

    try:
        return gl_state()
    except GLUnavailable as e:
        pytest.skip(str(e))
