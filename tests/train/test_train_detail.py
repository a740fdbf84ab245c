"""Detail where people look: crops centred on the head and hands, the facing-weighted colour
projection, the logit-space mask term and the detail preset."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from morf.errors import InputError
from morf.train.config import DETAIL_PRESET, PRESETS, preset
from morf.train.detail import crop_origins, detail_centres
from morf.train.frames import FrameSet
from morf.train.inpaint import project_rgb_texture
from morf.train.texel_splat import Projection
from morf.train.trainer import Trainer


def tiny(method="stylepeople", **kw):
    return preset("tiny", method, **kw)


def texture_init(cfg):
    return torch.rand(cfg.texture_channels, cfg.texture_size, cfg.texture_size)


def test_crop_origins_centre_clamp_and_missing_centres():
    rng = np.random.default_rng(0)
    ys, xs = crop_origins(np.array([[50.0, 40.0], [2.0, 99.0], [np.nan, np.nan]]), 20, 100, rng, jitter=0.0)
    assert (ys[0], xs[0]) == (30, 40)  # centred: x 50 -> columns 40..59, y 40 -> rows 30..49
    assert (ys[1], xs[1]) == (80, 0)  # a part at the border: the crop stays inside the image
    assert (ys[2], xs[2]) == (40, 40)  # no centre (a part off every view): the middle
    ys, xs = crop_origins(np.full((200, 2), 50.0), 20, 100, rng, jitter=0.25)
    assert ys.min() >= 35 and ys.max() <= 45 and len(set(ys.tolist())) > 3  # moved, by at most a quarter crop


def test_detail_centres_project_through_the_camera():
    from morf.camera import PinholeCamera

    cam = PinholeCamera(100.0, 100.0, 32.0, 32.0, 64, 64, np.eye(3), np.zeros(3))
    pts = np.array([[[0.0, 0.0, 2.0], [0.2, -0.1, 2.0], [0.0, 0.0, 1.0]]], np.float32)
    px = detail_centres(pts, cam)
    assert px.shape == (1, 3, 2)
    np.testing.assert_allclose(px[0], [[32, 32], [42, 27], [32, 32]], atol=1e-4)


def test_batch_at_given_origins_takes_those_pixels(frames_factory):
    fs = frames_factory(n=3, res=32)
    b = fs.batch([2, 0], crop=8, origins=(np.array([4, 20]), np.array([10, 0])))
    assert b.image.shape == (2, 3, 8, 8)
    want = torch.from_numpy(fs.images[2][4:12, 10:18]).permute(2, 0, 1).float() / 255
    assert torch.equal(b.image[0], want)
    assert torch.equal(b.mask[1, 0], torch.from_numpy(fs.masks[0][20:28, 0:8]).float())


def test_detail_steps_crop_around_the_parts(frames_factory):
    """Every detail_every-th step takes crops of the zoomed frames around the head or a hand."""
    cfg = tiny(resolution=32, zoom_resolution=64, steps=8, detail_every=4, batch_size=8)
    small, large = frames_factory(n=4, res=32), frames_factory(n=4, res=64)
    # a marker pixel at every frame's head and hands; everything else black
    images = np.zeros_like(large.images)
    centres = np.array([[[10, 12], [50, 40], [30, 54]]] * 4, np.float32) + np.arange(4)[:, None, None]
    for i, frame in enumerate(centres.astype(int)):
        for x, y in frame:
            images[i, y, x] = 255
    large = dataclasses.replace(large, images=images)
    tr = Trainer(cfg, small, texture_init(cfg), zoom_frames=large, detail_centres=centres)
    kinds = []
    for step in range(8):
        tr.step = step
        b = tr.next_batch()
        kinds.append(int((b.image.amax(dim=(1, 2, 3)) == 1).sum()))
    # steps 3 and 7 are detail crops: every one of the 8 images holds a marker (the crop is 32 px,
    # the part at most 4 px from its centre); random crops of the zoomed frames hold one in some
    assert kinds[3] == 8 and kinds[7] == 8
    assert min(kinds[1], kinds[5]) < 8
    assert tr.next_batch().image.shape[-1] == 32
    with pytest.raises(ValueError):  # centres for other frames
        Trainer(cfg, small, texture_init(cfg), zoom_frames=large, detail_centres=centres[:2])


def test_detail_settings_need_zoomed_frames():
    with pytest.raises(InputError, match="zoom_resolution"):
        tiny(resolution=32, detail_every=4)
    with pytest.raises(InputError, match="zoom_resolution"):
        tiny(resolution=32, colour_from_zoom=True)
    with pytest.raises(InputError, match="w_mask_bce"):
        tiny(w_mask_bce=-1.0)
    with pytest.raises(InputError, match="colour_facing_power"):
        tiny(colour_facing_power=-2.0)


def test_detail_preset_is_the_cpu_preset_with_detail():
    cpu, det = PRESETS["cpu"], PRESETS[DETAIL_PRESET]
    det.validate()
    assert det.renderer == cpu.renderer and det.resolution == cpu.resolution  # the same playback graph
    assert det.texture_size > cpu.texture_size and det.zoom_resolution >= 640
    assert det.detail_every and det.colour_from_zoom and det.w_mask_bce > 0
    assert det.colour_align_passes == 2 and cpu.colour_align_passes == 0  # aligned colour: the detail preset only
    # the projection without the speckle: both presets (the tiny one keeps the plain mean)
    assert cpu.colour_bilinear and det.colour_bilinear and cpu.colour_prior_count == det.colour_prior_count > 0
    assert not PRESETS["tiny"].colour_bilinear and PRESETS["tiny"].colour_prior_count == 0
    assert cpu.colour_from_zoom and not PRESETS["tiny"].colour_from_zoom  # the colour from the 512 px frames


def _two_views_of_one_texel(colours, facings) -> FrameSet:
    n = len(colours)
    images = np.zeros((n, 4, 4, 3), np.uint8)
    for i, c in enumerate(colours):
        images[i] = c
    uv = np.full((n, 4, 4, 2), 0.3, np.float32)  # every pixel hits the same texel
    fs = FrameSet.from_float(images, np.ones((n, 4, 4), bool), uv, np.ones((n, 4, 4), bool), np.zeros((n, 2, 3)))
    facing = np.stack([np.full((4, 4), round(f * 255), np.uint8) for f in facings])
    return dataclasses.replace(fs, facing=facing)


def test_facing_weighted_projection_keeps_the_frame_that_faces_the_texel():
    fs = _two_views_of_one_texel([(255, 0, 0), (0, 0, 255)], [1.0, 0.5])
    mean, seen = project_rgb_texture(fs, 8)
    sharp, seen_w = project_rgb_texture(fs, 8, how=Projection(facing_power=16))
    r, c = 5, 2  # row (1 - 0.3) * 8, column 0.3 * 8
    assert seen[r, c] and seen.sum() == 1 and np.array_equal(seen, seen_w)
    np.testing.assert_allclose(mean[r, c], [0.5, 0, 0.5], atol=1e-6)  # the plain mean blends the two
    assert sharp[r, c, 0] > 0.99 and sharp[r, c, 2] < 0.01  # weighted: the frame that faces it


def test_mask_logit_term_revives_a_dead_mask(frames_factory):
    """A mask logit far below zero everywhere: Dice (through the sigmoid) has no gradient left
    there, the logit-space term still pulls person pixels up."""
    from morf.avatar.model import AvatarOutput
    from morf.train.objective import generator_losses

    fs = frames_factory(n=2, res=32)
    batch = fs.batch([0, 1])
    logit = torch.full((2, 1, 32, 32), -30.0, requires_grad=True)
    out = AvatarOutput(torch.zeros(2, 3, 32, 32), logit, torch.zeros(2, 16, 32, 32), None)
    cfg = tiny(w_mask_bce=0.1)
    losses = generator_losses(cfg, out, batch)
    (dice_grad,) = torch.autograd.grad(losses["dice"], logit, retain_graph=True)
    (bce_grad,) = torch.autograd.grad(losses["mask_bce"], logit)
    person = batch.mask.bool()
    assert dice_grad.abs().max() < 1e-9
    assert (bce_grad[person] < -0.5 / person.numel()).all()  # about -1 / pixels on every person pixel
    assert "mask_bce" not in generator_losses(tiny(), out, batch)
