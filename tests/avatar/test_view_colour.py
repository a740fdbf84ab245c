"""View-dependent colour: anchors, the blend's weights, the projection per view, the bytes."""

import numpy as np
import pytest

from morf.avatar.view_colour import (BLEND, ViewColourBytes, ViewColours, anchor_weights, angles_between,
                                     quantize_view_colours, spread_anchors, view_orientation)
from morf.raster.texture_quant import ZERO_POINT, quantize_texture
from morf.rotations import rotvec_to_matrix_rodrigues
from morf.train.frames import FrameSet
from morf.train.view_colours import project_view_colours


def _yaw(deg):
    return rotvec_to_matrix_rodrigues(np.array([[0.0, np.radians(deg), 0.0]]))[0]


def test_rotations_and_angles():
    r = rotvec_to_matrix_rodrigues(np.array([[0.0, 0.3, 0.0], [0.1, -0.2, 0.4]]))
    assert np.allclose(r @ r.transpose(0, 2, 1), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(r), 1.0)
    assert angles_between(_yaw(10)[None], _yaw(40)[None])[0, 0] == pytest.approx(np.radians(30))
    # the orientation seen by a camera turned by the same yaw as the body is the rest orientation
    U = _yaw(25)
    assert np.allclose(view_orientation(_yaw(-30), U, np.array([0.0, np.radians(30), 0.0])), np.eye(3), atol=1e-9)


def test_anchors_spread_over_the_orientations():
    rots = np.stack([_yaw(d) for d in range(0, 360, 10)])
    picked = spread_anchors(rots, 4)
    yaws = sorted(int(round(np.degrees(np.arctan2(rots[i][0, 2], rots[i][0, 0])))) % 360 for i in picked)
    gaps = np.diff(yaws + [yaws[0] + 360])
    assert len(set(picked.tolist())) == 4 and gaps.min() >= 60  # four directions around the turn
    assert list(spread_anchors(rots[:3], 5)) == [0, 1, 2]


def test_blend_weights_are_continuous_as_the_body_turns():
    anchors = np.stack([_yaw(d) for d in (0, 90, 180, 270)])
    idx, w = anchor_weights(anchors, _yaw(0))
    assert w.sum() == pytest.approx(1.0) and idx[0] == 0 and w[0] > w[1]
    # half-way between two anchors: both alike and the heaviest; the farthest anchor never takes part
    idx, w = anchor_weights(anchors, _yaw(45))
    assert set(idx[:2].tolist()) == {0, 1} and w[0] == pytest.approx(w[1]) and w[:2].min() >= w.max() - 1e-12
    assert 2 not in idx.tolist() or 3 not in idx.tolist()
    assert len(idx) == min(BLEND, 4)
    prev = None
    for d in np.arange(0, 360, 0.5):  # no jump anywhere: the blended value of a per-anchor number
        idx, w = anchor_weights(anchors, _yaw(d))
        value = float(np.dot(w, np.cos(np.radians([0, 90, 180, 270]))[idx]))
        if prev is not None:
            assert abs(value - prev) < 0.05
        prev = value


def _frames(n=8, size=16):
    """A FrameSet of ``n`` frames turning about y, each a flat colour (frame i: i * 30 + 10 red)
    covering the whole texture through its UVs."""
    yy, xx = np.mgrid[0:size, 0:size]
    uv = np.stack([(xx + 0.5) / size, 1 - (yy + 0.5) / size], -1)[None].repeat(n, 0)
    images = np.zeros((n, size, size, 3), np.uint8)
    images[..., 0] = (np.arange(n) * 30 + 10)[:, None, None]
    rot = np.zeros((n, 2, 3), np.float32)
    rot[:, 0, 1] = np.radians(np.arange(n) * 45.0)
    return FrameSet.from_float(images, np.ones((n, size, size), bool), uv, np.ones((n, size, size), bool), rot)


def test_each_view_is_projected_from_the_frames_nearest_it():
    from morf.train.texel_splat import Projection

    fs = _frames()
    covered = np.ones((16, 16), bool)
    base = np.full((3, 16, 16), 0.5, np.float32)
    views = project_view_colours(fs, covered, base, 4, 1, 0, Projection(), np.eye(3), np.eye(3))
    assert views.colours.shape == (4, 3, 16, 16) and views.count == 4 and views.frames == 1
    for k in range(4):  # one frame each: the anchor's own frame's red
        i = int(np.argmin(angles_between(views.anchors[k:k + 1].astype(np.float64),
                                         rotvec_to_matrix_rodrigues(fs.rotvecs[:, 0]))[0]))
        assert np.all(np.abs(views.colours[k, 0].astype(int) - (i * 30 + 10)) <= 1)
    # a pose at an anchor's orientation is drawn mostly in that anchor's colour
    tex = views.texture_for(__import__("torch").zeros(16, 16, 16), fs.rotvecs[0, 0])
    assert tex.shape == (16, 16, 16) and float(tex[3:].abs().max()) == 0.0
    back = ViewColours.from_dict(views.to_dict())
    assert np.array_equal(back.colours, views.colours) and np.allclose(back.anchors, views.anchors)
    with pytest.raises(ValueError):
        ViewColours.from_dict({**views.to_dict(), "colours": views.to_dict()["colours"][:2]})


def test_bytes_are_the_textures_own():
    fs = _frames()
    from morf.train.texel_splat import Projection

    views = project_view_colours(fs, np.ones((16, 16), bool), np.zeros((3, 16, 16), np.float32), 3, 2, 0,
                                 Projection(), np.eye(3), np.eye(3))
    tex = np.zeros((16, 16, 16), np.float32)
    tex[:3] = views.colours[1] / 255.0
    q = quantize_texture(tex)
    b = quantize_view_colours(views, q.scales[:3], ZERO_POINT)
    assert isinstance(b, ViewColourBytes) and b.data.shape == (3, 16, 16, 3)
    assert np.abs(b.data[1].astype(int) - q.data[..., :3]).max() <= 1
    idx, w = anchor_weights(b.anchors, b.anchors[1].astype(np.float64))
    want = sum(wi * b.data[i].astype(np.float64) for i, wi in zip(idx, w))
    assert idx[0] == 1 and np.abs(b.blend(b.anchors[1].astype(np.float64)).astype(float) - want).max() <= 0.5


def test_the_root_frame_is_the_skeletons(body_model):
    import torch

    from morf.body.anny_model import reference_rotations
    from morf.export.skeleton import skeleton_from_body_model

    shape = np.zeros((1, 6), np.float32)
    want = skeleton_from_body_model(body_model, torch.from_numpy(shape)).reference_rotations
    assert np.allclose(reference_rotations(body_model, shape), want, atol=1e-9)
    rest = body_model.rest(torch.from_numpy(shape))["rest_bone_poses"][0]
    assert np.allclose(reference_rotations(body_model, shape, rest), want, atol=1e-9)


def test_a_view_keeps_only_the_texels_its_frames_saw_squarely():
    import dataclasses

    from morf.train.texel_splat import Projection
    from morf.train.view_colours import squareness

    fs = _frames()
    facing = np.stack([np.full((16, 16), 255 - 25 * i, np.uint8) for i in range(fs.num_frames)])  # frame 0 squarest
    fs = dataclasses.replace(fs, facing=facing)
    covered = np.ones((16, 16), bool)
    assert np.allclose(squareness(fs, covered, Projection(), 64.0), 1.0, atol=0.02)  # about the best frame's
    base = np.full((3, 16, 16), 0.5, np.float32)
    views = project_view_colours(fs, covered, base, 8, 1, 0, Projection(), np.eye(3), np.eye(3), margin=0.2)
    from morf.train.view_colours import SQUARE_POWER

    best = float(squareness(fs, covered, Projection(), SQUARE_POWER).mean())  # about frame 0's 1.0
    assert 0.9 < best <= 1.0
    mixes = []
    for k in range(8):
        i = int(np.argmin(angles_between(views.anchors[k:k + 1].astype(np.float64),
                                         rotvec_to_matrix_rodrigues(fs.rotvecs[:, 0]))[0]))
        gap = best - (255 - 25 * i) / 255  # how much less squarely frame i saw every texel than the best
        mix = np.clip((0.2 - gap) / 0.2, 0, 1)
        mixes.append(mix)
        want = mix * (i * 30 + 10) + (1 - mix) * 127.5
        assert np.abs(views.colours[k, 0].astype(float) - want).max() <= 2.0, (k, i)
    assert max(mixes) == 1.0 and min(mixes) == 0.0  # the squarest view's own colour, the slanted ones the base


def test_blend_weights_are_squared_so_the_nearest_anchor_leads():
    anchors = np.stack([_yaw(d) for d in (0, 90, 180, 270)])
    idx, w = anchor_weights(anchors, _yaw(20))  # 20, 70, 110 degrees from the three nearest; 160 from the next
    assert idx.tolist() == [0, 1, 3]
    want = np.array([140.0, 90.0, 50.0]) ** 2
    np.testing.assert_allclose(w, want / want.sum(), atol=1e-9)
