"""Shared fixtures: one body model per test session, small synthetic data, shared data path."""

from __future__ import annotations

import contextlib
import fcntl
import importlib
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MORF_QUIET", "1")

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


def pytest_configure(config):
    """Under pytest-xdist (``-n N``) each worker gets its share of the cores for torch, so that N
    workers do not each start a thread per core and wait on one another's threads."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if os.environ.get("PYTEST_XDIST_WORKER") and workers > 1:
        import torch

        torch.set_num_threads(max(1, (os.cpu_count() or 1) // workers))


# The files that take longest on two cores (``--durations=0`` summed per file, slowest first). The
# suite hands whole files to its workers (``--dist loadfile``) in collection order
# (``--no-loadscope-reorder``: xdist would otherwise start the files with the most tests first),
# so these start first and the short files fill in around them: the workers end together instead
# of one of them starting the sweep's trainings when the other is nearly done.
SLOWEST_FILES = (
    "tests/web/test_web_page.py", "tests/test_scale_ray.py", "tests/bench/test_pareto.py",
    "tests/cli/test_hostile_inputs.py", "tests/bench/test_quality.py", "tests/export/test_onnx_renderer.py",
    "tests/motion/test_motion_checks_cli.py", "tests/fitting/test_fit_resume.py", "tests/export/test_gltf_browser.py",
    "tests/studio/test_bench.py", "tests/train/test_training.py",
    "tests/evaluate/test_eval_cli.py", "tests/studio/test_pipeline_ui.py", "tests/export/test_project_export.py",
    "tests/cli/test_demo.py", "tests/test_dependencies.py", "tests/bench/test_stability.py",
)


def pytest_collection_modifyitems(session, config, items):
    """:data:`SLOWEST_FILES` first, in that order; every other file after them as collected (the
    tests of one file keep their order)."""
    rank = {path: i for i, path in enumerate(SLOWEST_FILES)}
    place = lambda item: rank.get(item.nodeid.split("::", 1)[0], len(rank))  # noqa: E731
    items[:] = sorted(items, key=place)  # sorted() is stable


def strict_install() -> bool:
    """Whether this run has every declared dependency installed, so that a missing one is a broken
    install that fails its tests instead of skipping them: ``MORF_REQUIRE_DEPS=1``, or
    ``MORF_REQUIRE_GL=1`` (CI, after ``scripts/install.sh``, sets it)."""
    return os.environ.get("MORF_REQUIRE_DEPS") == "1" or os.environ.get("MORF_REQUIRE_GL") == "1"


def require(module: str):
    """``module`` imported, for a test (or, at module level, a test file) that needs it.

    Where it cannot be imported the test is skipped, except under :func:`strict_install`, where
    it fails: pyproject.toml declares it (or scripts/install.sh installs it), so CI must run those
    tests, not pass them as skips. Use it instead of ``pytest.importorskip``::

        imgui = require("imgui_bundle").imgui
    """
    try:
        return importlib.import_module(module)
    except ImportError as e:
        error = e  # reported below, outside the handler: one line, no chained traceback
    if strict_install():
        pytest.fail(f"{module} cannot be imported ({error}) although this install should have it "
                    "(MORF_REQUIRE_DEPS / MORF_REQUIRE_GL is set): run bash scripts/install.sh", pytrace=False)
    pytest.skip(f"{module} is not installed ({error})", allow_module_level=True)


IMPORT_SKIP = "could not import "  # how pytest.importorskip words its skip


def _fail_an_import_skip(report) -> None:
    """Under :func:`strict_install`, a ``pytest.importorskip`` skip (of a test or of a whole file at
    collection) becomes a failure: the install is broken, and a skip would hide it."""
    if not (report.skipped and strict_install() and isinstance(report.longrepr, tuple)):
        return
    reason = str(report.longrepr[2]).removeprefix("Skipped: ")
    if reason.startswith(IMPORT_SKIP):
        report.outcome = "failed"
        report.longrepr = (f"{reason}, although this install should have it (MORF_REQUIRE_DEPS / MORF_REQUIRE_GL "
                           "is set): run bash scripts/install.sh")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    _fail_an_import_skip(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    _fail_an_import_skip(outcome.get_result())


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
    """A headless OpenGL (EGL) context; tests that need one skip cleanly where EGL is missing, and
    fail there under ``MORF_REQUIRE_GL=1`` (CI on a machine with EGL: they must run, not skip)."""
    from morf.raster import GLUnavailable, gl_state

    try:
        return gl_state()
    except GLUnavailable as e:
        if os.environ.get("MORF_REQUIRE_GL") == "1":
            pytest.fail(f"MORF_REQUIRE_GL=1 but there is no headless OpenGL here: {e}")
        pytest.skip(str(e))


@pytest.fixture(scope="module")
def one_torch_thread():
    """Torch on one thread for a module: tiny tensors gain nothing from a second one, and the
    trainings of a whole pipeline run take less than half the time without the thread hand-offs."""
    import torch

    prev = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(prev)


@pytest.fixture(scope="session")
def lpips_weights(tmp_path_factory):
    """Random LPIPS weights in the layouts MoRF reads: ``(lin, vgg)`` paths of a state dict in the
    lpips package's ``vgg.pth`` layout (positive lin weights) and a torchvision-format VGG-16."""
    import torch

    from morf.avatar.lpips import LIN_CHANNELS, LIN_KEYS
    from morf.avatar.vgg import VGG16Features

    root = tmp_path_factory.mktemp("lpips")
    gen = torch.Generator().manual_seed(0)
    with torch.random.fork_rng():
        torch.manual_seed(0)
        vgg = {k: v.clone() for k, v in VGG16Features().state_dict().items()}  # keys features.N.weight / .bias
    vgg["classifier.0.weight"] = torch.zeros(2, 2)  # torchvision files carry the classifier too
    lin = {k: torch.rand(1, c, 1, 1, generator=gen) + 0.01 for k, c in zip(LIN_KEYS, LIN_CHANNELS)}
    torch.save(vgg, root / "vgg16.pth")
    torch.save(lin, root / "lpips-vgg.pth")
    return root / "lpips-vgg.pth", root / "vgg16.pth"


@pytest.fixture(scope="module")
def local_ray(tmp_path_factory):
    """A local Ray of two CPUs (two workers at once), no dashboard, a small object store.

    Under pytest-xdist the test files that use it run one at a time (a file lock in the run's
    temporary folder, which the workers share): two local clusters side by side would each start
    two workers on the same two cores."""
    from morf.scale.ray_runtime import RayOptions, connect

    ray = require("ray")
    with contextlib.ExitStack() as stack:
        if os.environ.get("PYTEST_XDIST_WORKER"):
            lock = stack.enter_context(open(tmp_path_factory.getbasetemp().parent / "local-ray.lock", "w"))
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if ray.is_initialized():
            ray.shutdown()
        connect(RayOptions(num_cpus=2, object_store_memory=80 * 1024**2))
        yield ray
        ray.shutdown()


@pytest.fixture()
def still_pose():
    """A fixed, slightly bent pose of Anny's 104 joints, turned 0.4 rad about the vertical."""
    rng = np.random.default_rng(7)
    rot = (rng.normal(size=(104, 3)) * 0.1).astype(np.float32)
    rot[0] = (0, 0, 0.4)
    return rot, np.array([0.02, 0.0, 0.0], np.float32)


@pytest.fixture(scope="session")
def tiny_capture_source(tmp_path_factory, body_model) -> Path:
    """The folder of a tiny synthetic capture (``synth_config("tiny")``: 12 frames), rendered once
    per session. Never written to: a test that writes into a capture takes a copy
    (:func:`tiny_capture`, :func:`copy_capture`)."""
    from morf.synth import make_synthetic_capture, synth_config

    root = tmp_path_factory.mktemp("tiny-capture") / "tiny"
    return make_synthetic_capture(root, synth_config("tiny"), model=body_model).root


def copy_capture(source: Path, dest: Path):
    """A copy of the capture project ``source`` at ``dest`` (which must not exist), opened."""
    from morf.capture.project import CaptureProject

    shutil.copytree(source, dest)
    return CaptureProject.open(dest)


@pytest.fixture()
def tiny_capture(tiny_capture_source, tmp_path):
    """A fresh copy of the session's tiny synthetic capture (a CaptureProject at ``tmp_path/cap``)."""
    return copy_capture(tiny_capture_source, tmp_path / "cap")


@pytest.fixture(scope="session")
def tiny_avatar(tmp_path_factory, body_model):
    """A tiny exported avatar whose renderer's mask follows the mesh coverage, so renders are checkable."""
    from types import SimpleNamespace

    from morf.export.synthetic import build_synthetic_avatar, coverage_renderer, coverage_texture

    out = tmp_path_factory.mktemp("avatar") / "avatar"
    build_synthetic_avatar(out, body_model=body_model, renderer=coverage_renderer(), texture=coverage_texture(),
                           image_size=64, calibration_views=3, heldout_views=1,
                           renderer_cfg=SimpleNamespace(in_channels=16))
    return out
