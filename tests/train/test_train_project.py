"""Integration: a tiny synthetic capture -> training frames (GL rasterization, cached) -> a few
training steps with inpainting -> avatar.pt -> hold-out evaluation."""

import numpy as np
import pytest

pytestmark = [pytest.mark.slow, pytest.mark.gl]


@pytest.fixture(scope="module")
def tiny_capture(tmp_path_factory, tiny_capture_source, gl):
    """A copy of the session's tiny capture (12 frames, 4 of them held out): the test writes a run into it."""
    from tests.conftest import copy_capture

    return copy_capture(tiny_capture_source, tmp_path_factory.mktemp("cap") / "p")


def test_train_project_end_to_end(tiny_capture, body_model, tmp_path, monkeypatch):
    from morf.train.config import preset
    from morf.train.data import build_frames, build_holdout_frames
    from morf.train.project_run import evaluate_frames, train_project
    from morf.train.trained_avatar import load_trained_avatar

    monkeypatch.setenv("MORF_CACHE_DIR", str(tmp_path))
    cfg = preset("tiny", "morf", steps=3, resolution=64, texture_size=64, inpaint_steps=2, inpaint_views=2,
                 device="cpu")
    res = train_project(tiny_capture, cfg, "t", fits_source="ground-truth", model=body_model)
    assert res.step == 3
    log = (res.run_dir / "train.log").read_text()
    assert "inpainting" in log and "fits: ground-truth" in log
    pf = build_frames(tiny_capture, body_model, 64, "ground-truth")  # now from the cache
    assert pf.cache_path.is_file() and pf.frames.uv.shape[1:] == (64, 64, 2)
    iou = (pf.frames.masks & pf.frames.uv_mask).sum() / (pf.frames.masks | pf.frames.uv_mask).sum()
    assert iou > 0.6  # ground-truth meshes line up with the person masks
    av = load_trained_avatar(res.run_dir)
    assert av.camera is not None and av.shape.shape == (1, 6)
    hold = build_holdout_frames(tiny_capture, body_model, av.camera, av.shape.numpy())
    m = evaluate_frames(av, hold)
    assert m.frames == 4 and np.isfinite(m.psnr) and 0 <= m.ssim <= 1 and np.isfinite(m.temporal)
    # the warping-error flicker only where the frames are large enough for optical flow (32 px and up)
    assert list(m.to_dict()) == ["psnr", "ssim", "psnr_person", "ssim_person", "temporal", "background", "frames",
                                 *([] if m.warp_flicker is None else ["warp_flicker"])]
    assert m.to_dict()["background"] == list(m.background) and len(m.background) == 3
