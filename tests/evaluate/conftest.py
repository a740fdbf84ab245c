"""One tiny synthetic capture trained with a hold-out and evaluated once, shared by the eval tests."""

from __future__ import annotations

import json

import pytest
import torch


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    """Tiny tensors gain nothing from a second thread (see tests/train/conftest.py)."""
    prev = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(prev)


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory, gl, tiny_capture_source):
    """``morf train --holdout 3 --preset tiny`` (2 steps) then ``morf eval`` on a copy of the
    session's tiny synthetic capture (``synth_config("tiny")``, rendered once for all test files).

    Returns a dict: project (CaptureProject), run (its run name), eval (eval.json), out (the eval
    folder), stdout (what ``morf eval`` printed).
    """
    from morf.cli.main import main
    from tests.conftest import copy_capture

    root = tmp_path_factory.mktemp("eval") / "cap"
    project = copy_capture(tiny_capture_source, root)
    assert main(["train", str(root), "--preset", "tiny", "--steps", "2", "--holdout", "3", "--device", "cpu"]) == 0
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), pytest.MonkeyPatch.context() as mp:
        mp.delenv("MORF_LPIPS_WEIGHTS", raising=False)  # a user's LPIPS weights must not change this test
        mp.delenv("MORF_VGG16_WEIGHTS", raising=False)
        assert main(["eval", str(root)]) == 0
    out = root / "eval"
    return {"project": project, "run": "morf-tiny", "eval": json.loads((out / "eval.json").read_text()), "out": out,
            "stdout": buf.getvalue()}
