"""Pose refinement (``morf eval --refine-poses``) on the body the avatar trained on: dressed by the
fit's clothing offsets, so the refined frames are rasterized with the loose clothes the renderer
learned, and the refinement does not pull the pose to fit the naked body inside them."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import torch

from tests.evaluate.test_pose_refine import _pattern_texture
from tests.train.dressed_fits import height_offsets, write_dressed_fits

pytestmark = [pytest.mark.gl]


def _dressed_truth(body_model, side: int = 96):
    """A frozen avatar (the pattern texture, passed through) rendered on the body dressed by 1-5 cm
    offsets in a known pose: (camera, shape, avatar, colour, frames, rotvecs, transl, offsets)."""
    from morf.avatar.metrics import composite_over
    from morf.avatar.model import render_with_texture
    from morf.avatar.passthrough import PassthroughRenderer
    from morf.raster.camera_paths import front_camera
    from morf.train.data import rasterize_frames
    from morf.train.frames import FrameSet

    cam = front_camera(side, center=(0.0, -0.3, 0.0))
    shape = body_model.default_shape().reshape(1, -1).numpy()
    avatar = SimpleNamespace(renderer=PassthroughRenderer(), texture=_pattern_texture())
    colour = torch.tensor([0.2, 0.3, 0.4])
    rot = np.zeros((1, len(body_model.bone_names), 3), np.float32)
    rot[0, 0] = (0.0, 0.0, 0.5)
    tr = np.zeros((1, 3), np.float32)
    offsets = height_offsets(body_model)
    uv, uvm, _ = next(rasterize_frames(body_model, rot, tr, shape, cam, offsets=offsets))
    rgb, alpha = render_with_texture(avatar.renderer, avatar.texture, torch.from_numpy(uv), torch.from_numpy(uvm))
    img = (composite_over(rgb, alpha, colour).permute(0, 2, 3, 1).numpy() * 255 + 0.5).astype(np.uint8)
    return cam, shape, avatar, colour, FrameSet.from_float(img, uvm, uv, uvm, rot), rot, tr, offsets


def test_refinement_draws_the_dressed_body(gl, body_model):
    """In the true pose the dressed body reproduces the frame (the naked one misses the clothes'
    rim), and the re-rasterized frames cover what the dressed body covers."""
    from morf.evaluate.pose_refine import RefineConfig, refine_poses, reposed_frames
    from morf.train.data import rasterize_frames

    cam, shape, avatar, colour, frames, rot, tr, offsets = _dressed_truth(body_model)
    still = RefineConfig(steps=0)  # the loss in the given pose, nothing moved
    dressed = refine_poses(avatar, body_model, frames, rot, tr, shape, cam, colour, still, offsets=offsets)
    naked = refine_poses(avatar, body_model, frames, rot, tr, shape, cam, colour, still)
    assert dressed.loss_before < 0.2 * naked.loss_before, (dressed.loss_before, naked.loss_before)
    assert dressed.offsets is offsets and naked.offsets is None
    again = reposed_frames(frames, body_model, dressed, shape, cam)
    naked_cover = next(rasterize_frames(body_model, rot, tr, shape, cam))[1]
    assert np.array_equal(again.uv_mask, frames.uv_mask)
    assert again.uv_mask.sum() > 1.1 * naked_cover.sum()


def test_refinement_from_a_moved_pose_keeps_the_dressed_body(gl, body_model):
    """Refined from a shifted start, the poses come back towards the truth on the dressed body and
    the re-rasterized frames are dressed."""
    from morf.evaluate.pose_refine import RefineConfig, refine_poses, reposed_frames

    from morf.train.data import rasterize_frames

    cam, shape, avatar, colour, frames, rot, tr, offsets = _dressed_truth(body_model)
    start = tr + np.array([[0.04, 0.0, 0.03]], np.float32)
    res = refine_poses(avatar, body_model, frames, rot, start, shape, cam, colour, RefineConfig(steps=15),
                       offsets=offsets)
    err = (np.linalg.norm(start - tr), np.linalg.norm(res.transl - tr))
    print(f"\nL1 {res.loss_before:.4f} -> {res.loss_after:.4f}; translation error {err[0]:.4f} -> {err[1]:.4f} m")
    assert res.loss_after < 0.7 * res.loss_before and err[1] < 0.6 * err[0]
    again = reposed_frames(frames, body_model, res, shape, cam).uv_mask
    naked = next(rasterize_frames(body_model, res.rotvecs, res.transl, shape, cam))[1]
    assert again.sum() > 1.1 * naked.sum()


def test_eval_refine_poses_draws_the_dressed_body(tiny_capture, body_model, gl, tmp_path, monkeypatch):
    """``morf eval --refine-poses`` on a run trained on the dressed body: every re-rasterization of
    the refined poses carries the fit's offsets and covers more than the naked body would."""
    import dataclasses

    from morf.cli.main import main
    from morf.evaluate import pose_refine
    from morf.train.data import rasterize_frames

    offsets = height_offsets(body_model)
    write_dressed_fits(tiny_capture, body_model, offsets)
    root = str(tiny_capture.root)
    assert main(["train", root, "--preset", "tiny", "--steps", "2", "--holdout", "3", "--set", "inpaint_steps=0"]) == 0
    real_refine, real_repose, seen = pose_refine.refine_poses, pose_refine.reposed_frames, []

    def two_steps(*args, **kwargs):
        """The command's refinement with 2 Adam steps a frame: the body drawn is what is checked."""
        return real_refine(*args[:-1], dataclasses.replace(args[-1], steps=2), **kwargs)

    def spy(frames, model, refined, shape, camera):
        out = real_repose(frames, model, refined, shape, camera)
        naked = np.concatenate([m for _, m, _ in rasterize_frames(model, refined.rotvecs, refined.transl,
                                                                  np.asarray(shape).reshape(1, -1), camera)])
        seen.append((refined.offsets, int(out.uv_mask.sum()), int(naked.sum())))
        return out

    monkeypatch.setattr(pose_refine, "refine_poses", two_steps)
    monkeypatch.setattr(pose_refine, "reposed_frames", spy)
    assert main(["eval", root, "--refine-poses", "--out", str(tmp_path / "eval")]) == 0
    assert seen
    for used, dressed, naked in seen:
        assert used is not None and np.array_equal(used, offsets)
        assert dressed > 1.05 * naked, (dressed, naked)
