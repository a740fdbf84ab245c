"""Flow-aligned colour projection: frames misaligned by a known shift project sharper once aligned."""

import cv2
import numpy as np
import pytest

from morf.errors import InputError
from morf.train.colour_align import aligned_floor_texture, sample_colour
from morf.train.config import preset
from morf.train.frames import FrameSet, pack_uv

S = 96  # texture side = image side: one pixel per texel
SHIFTS = [(0, 0), (3, 0), (-3, 0), (0, 3), (0, -3), (2, 2), (-2, -2)]  # zero mean: the consensus is the truth
BOX = (slice(24, 72), slice(24, 72))  # the "face": the sub-region the fit misplaces


def truth_texture(seed=0):
    """(S, S, 3) float32 detail: blurred noise, texture a flow can lock onto."""
    rng = np.random.default_rng(seed)
    noise = rng.random((S, S, 3)).astype(np.float32)
    return cv2.GaussianBlur(noise, (0, 0), 1.2)


def shifted_frames(truth):
    """Frames that all show ``truth`` one texel per pixel, but whose fitted UVs misplace the box
    ``BOX`` by a per-frame shift: a pixel there claims to see the texel ``shift`` away."""
    ys, xs = np.mgrid[0:S, 0:S].astype(np.float32)
    images, uvs = [], []
    for dx, dy in SHIFTS:
        ox, oy = np.zeros((S, S), np.float32), np.zeros((S, S), np.float32)
        ox[BOX], oy[BOX] = dx, dy
        ox, oy = cv2.GaussianBlur(ox, (0, 0), 3), cv2.GaussianBlur(oy, (0, 0), 3)  # a smooth misfit
        uvs.append(np.stack([(xs + 0.5 + ox) / S, 1 - (ys + 0.5 + oy) / S], -1))
        images.append(np.round(truth * 255))
    n = len(SHIFTS)
    return FrameSet.from_float(np.stack(images), np.ones((n, S, S), bool), np.stack(uvs), np.ones((n, S, S), bool),
                               np.zeros((n, 1, 3)))


def box_error(texture, truth):
    return float(np.abs(texture[:3].transpose(1, 2, 0)[BOX] - truth[BOX]).mean())


def test_aligned_projection_is_closer_to_the_truth_than_the_plain_one():
    truth = truth_texture()
    frames = shifted_frames(truth)
    covered = np.ones((S, S), bool)
    plain, _, none = aligned_floor_texture(frames, covered, passes=0, dilate=0)
    aligned, seen, info = aligned_floor_texture(frames, covered, passes=2, dilate=0, max_flow=5)
    assert none.passes == 0 and none.flow_median == ()
    assert info.passes == 2 and len(info.flow_median) == len(info.flow_p95) == 2
    assert info.flow_p95[0] > 1.0  # the frames were found misaligned by pixels, not fractions
    err_plain, err_aligned = box_error(plain, truth), box_error(aligned, truth)
    assert err_aligned < 0.6 * err_plain, (err_plain, err_aligned)
    # outside the misfit box the frames agreed all along: alignment must not disturb it
    outside = np.ones((S, S), bool)
    outside[16:80, 16:80] = False
    diff = np.abs(aligned[:3] - plain[:3]).transpose(1, 2, 0)[outside & seen]
    assert float(diff.mean()) < 0.01


def test_flow_clamp_limits_the_correction():
    truth = truth_texture(1)
    frames = shifted_frames(truth)
    covered = np.ones((S, S), bool)
    plain = aligned_floor_texture(frames, covered, passes=0, dilate=0)[0]
    clamped = aligned_floor_texture(frames, covered, passes=1, dilate=0, max_flow=0.0)[0]
    np.testing.assert_allclose(clamped, plain, atol=1e-6)  # zero flow: the frames are not moved


def test_sample_colour_reads_the_texel_each_pixel_sees():
    rgb = np.random.default_rng(2).random((8, 8, 3)).astype(np.float32)
    ys, xs = np.mgrid[0:8, 0:8]
    uv = pack_uv(np.stack([(xs + 0.5) / 8, 1 - (ys + 0.5) / 8], -1))
    mask = np.ones((8, 8), bool)
    mask[0, 0] = False
    out = sample_colour(rgb, uv, mask)
    np.testing.assert_allclose(out[1:, 1:], rgb[1:, 1:], atol=1e-3)
    assert (out[0, 0] == 0).all()


def test_colour_align_passes_must_not_be_negative():
    with pytest.raises(InputError, match="colour_align_passes"):
        preset("tiny", "stylepeople", colour_align_passes=-1)


@pytest.mark.slow
@pytest.mark.gl
def test_training_with_aligned_colour_notes_it(tiny_capture_source, body_model, tmp_path_factory, monkeypatch):
    from tests.conftest import copy_capture
    from morf.train.project_run import train_project

    project = copy_capture(tiny_capture_source, tmp_path_factory.mktemp("cap") / "p")
    monkeypatch.setenv("MORF_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    cfg = preset("tiny", "morf", steps=2, resolution=64, texture_size=64, inpaint_steps=1, inpaint_views=2,
                 device="cpu", colour_align_passes=1)
    res = train_project(project, cfg, "aligned", fits_source="ground-truth", model=body_model)
    log = (res.run_dir / "train.log").read_text()
    assert "colour aligned by optical flow over 1 pass(es)" in log


@pytest.mark.slow
@pytest.mark.gl
def test_morf_train_takes_the_splat_and_the_prior_and_notes_them(tiny_capture, tmp_path, monkeypatch):
    """``morf train --set colour_bilinear=true --set colour_prior_count=4``: the run's config keeps
    both, and its log says how the colour was projected."""
    import json

    from morf.cli.main import main

    monkeypatch.setenv("MORF_CACHE_DIR", str(tmp_path / "cache"))
    root = str(tiny_capture.root)
    assert main(["train", root, "--preset", "tiny", "--steps", "2", "--name", "splat", "--fits", "ground-truth",
                 "--set", "inpaint_steps=0", "--set", "colour_bilinear=true", "--set", "colour_prior_count=4"]) == 0
    run = tiny_capture.root / "runs" / "splat"
    cfg = json.loads((run / "config.json").read_text())
    assert cfg["colour_bilinear"] is True and cfg["colour_prior_count"] == 4
    log = (run / "train.log").read_text()
    assert "each pixel shared among four texels" in log and "drawn to their neighbourhood (4 pixels)" in log
