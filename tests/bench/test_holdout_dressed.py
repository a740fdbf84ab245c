"""``morf bench quality`` / ``morf bench pareto`` hold-out scoring (:func:`holdout_quality`) draws the
body the run trained on: dressed by the fit's clothing offsets, or naked for a
``--set dressed=false`` run."""

from __future__ import annotations

import numpy as np
import pytest

from morf.cli.main import main
from tests.train.dressed_fits import height_offsets, write_dressed_fits

pytestmark = pytest.mark.gl


def test_holdout_quality_scores_the_dressed_body(tiny_capture, body_model, gl, one_torch_thread, monkeypatch):
    import morf.train.data as data
    from morf.bench.train_eval import holdout_quality

    offsets = height_offsets(body_model)
    write_dressed_fits(tiny_capture, body_model, offsets)
    root = str(tiny_capture.root)
    common = ["--preset", "tiny", "--steps", "2", "--set", "inpaint_steps=0"]
    assert main(["train", root, *common, "--name", "dressed"]) == 0
    assert main(["train", root, *common, "--name", "naked", "--set", "dressed=false"]) == 0
    real, seen = data.build_holdout_frames, []

    def spy(project, model, working, shape, fits=None, offsets=None):
        frames = real(project, model, working, shape, fits, offsets)
        seen.append((offsets, int(frames.uv_mask.sum())))
        return frames

    monkeypatch.setattr(data, "build_holdout_frames", spy)
    scores = {name: holdout_quality(tiny_capture, tiny_capture.runs_dir / name, body_model)
              for name in ("dressed", "naked")}
    (dressed_offsets, dressed_cover), (naked_offsets, naked_cover) = seen
    assert dressed_offsets is not None and np.array_equal(dressed_offsets, offsets)
    assert naked_offsets is None
    assert dressed_cover > 1.05 * naked_cover, (dressed_cover, naked_cover)
    assert all(np.isfinite(s.psnr) for s in scores.values())
