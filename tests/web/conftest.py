"""Fixtures of the web player's tests: web folders of the shared tiny avatar (whole-graph renderer)
and of a synthetic avatar with the cpu preset's renderer (the graph cut before its tail), and the
page driven in headless Chromium. Without Chromium or the cached onnxruntime-web the browser tests
skip, and fail under MORF_REQUIRE_DEPS / MORF_REQUIRE_GL (scripts/test.sh installs both)."""

from __future__ import annotations

import pytest

from tests.conftest import strict_install


def browser_or_skip() -> None:
    """Skip (fail in a strict install) where the page cannot run: no Chromium, no cached libraries."""
    from morf.errors import InputError
    from morf.web.browser import missing_browser
    from morf.web.libraries import ort_dist

    why = missing_browser()
    if why is None:
        try:
            ort_dist()
        except InputError as e:
            why = str(e)
    if why is None:
        return
    if strict_install():
        pytest.fail(f"the web player cannot run here although this install should have it: {why}", pytrace=False)
    pytest.skip(f"the web player in Chromium: {why}")


@pytest.fixture(scope="module")
def tiny_web(tiny_avatar, tmp_path_factory):
    """The tiny avatar's web folder (its renderer has no tail: the page runs the whole graph)."""
    browser_or_skip()
    from morf.web.build import build_web_folder

    return build_web_folder(tiny_avatar, tmp_path_factory.mktemp("web") / "tiny")


@pytest.fixture(scope="module")
def tail_avatar(tmp_path_factory, body_model):
    """A synthetic avatar with the cpu preset's (random) renderer: its manifest has the tail's spec."""
    browser_or_skip()
    from morf.export.synthetic import build_synthetic_avatar

    out = tmp_path_factory.mktemp("tail") / "avatar"
    build_synthetic_avatar(out, body_model=body_model, image_size=64, texture_size=64, calibration_views=3,
                           heldout_views=1)
    return out


@pytest.fixture(scope="module")
def tail_web(tail_avatar, tmp_path_factory):
    from morf.web.build import build_web_folder

    return build_web_folder(tail_avatar, tmp_path_factory.mktemp("web") / "tail")
