"""GL neural rasterization against the training path: rasterize_uv + torch grid_sample."""

import numpy as np
import pytest

from morf.export.export_avatar import skinned_mesh_from_body_model
from morf.export.skeleton import skeleton_from_body_model
from morf.raster.camera_paths import front_camera
from morf.raster.gl_context import create_headless_context
from morf.raster.neural_raster import NeuralRasterizer
from morf.raster.texture_quant import quantize_texture, sinusoid_texture
from raster_reference import training_raster_bytes

pytestmark = pytest.mark.gl


@pytest.mark.parametrize("cpu_skinning", [True, False])
def test_gl_matches_torch_sampling(body_model, still_pose, cpu_skinning):
    """Skinned on the CPU (numba, the default) or in the vertex shader (where numba is missing)."""
    shape = body_model.default_shape()
    q = quantize_texture(sinusoid_texture(16, 128, seed=2))
    skel = skeleton_from_body_model(body_model, shape)
    cam = front_camera(128, yaw_deg=30)
    rot, tr = still_pose
    ctx = create_headless_context()
    try:
        nr = NeuralRasterizer(ctx, skinned_mesh_from_body_model(body_model, shape), q, 128, 128, skel.num_bones,
                              cpu_skinning=cpu_skinning)
        assert nr.cpu_skinning == cpu_skinning
        nr.draw(skel.bone_transforms(rot, tr), cam)
        gl = nr.read().transpose(2, 0, 1).astype(np.int32)  # (H, W, 16) channels last
        nr.release()
    finally:
        ctx.release()
    ref, covered = training_raster_bytes(body_model, shape, q, rot, tr, cam)
    diff = np.abs(gl - ref).max(axis=0)
    assert covered.sum() > 800  # enough body pixels for the statistics below
    assert (diff[covered] <= 1).mean() > 0.99  # bilinear filter rounding: at most 1 LSB
    assert (diff[~covered] == 0).mean() > 0.99  # background is exactly the zero point
    assert np.all(gl[:, ~covered][:, :100] == 128)


def test_the_body_is_marked_in_the_coverage_byte(body_model, still_pose):
    """A texture whose every value is 0 (byte 128): on the body only the coverage byte moves, to
    129; off it every byte stays 128. The renderer graph finds the body from that byte alone."""
    from morf.raster.neural_raster import COVERAGE_CHANNEL, mark_coverage
    from morf.raster.texture_quant import QuantizedTexture

    shape = body_model.default_shape()
    q = QuantizedTexture(np.full((64, 64, 16), 128, np.uint8), np.ones(16, np.float32))
    skel = skeleton_from_body_model(body_model, shape)
    rot, tr = still_pose
    ctx = create_headless_context()
    try:
        nr = NeuralRasterizer(ctx, skinned_mesh_from_body_model(body_model, shape), q, 96, 96, skel.num_bones)
        nr.draw(skel.bone_transforms(rot, tr), front_camera(96))
        gl = nr.read().copy()
        nr.release()
    finally:
        ctx.release()
    body = gl[..., COVERAGE_CHANNEL] != 128
    assert 0.05 < body.mean() < 0.6  # the body is there, seen through that byte alone
    assert np.all(gl[body, COVERAGE_CHANNEL] == 129)
    others = np.delete(gl, COVERAGE_CHANNEL, axis=-1)
    assert np.all(others == 128) and np.all(gl[~body] == 128)

    # the same mark on a raster made elsewhere
    x = np.full((2, 3, 16), 128, np.uint8)
    x[0, 0, 5] = 140  # on the body through another channel: the coverage byte moves
    x[0, 1, COVERAGE_CHANNEL] = 90  # already marked: kept
    marked = mark_coverage(x.copy(), channel_axis=-1)
    assert marked[0, 0, COVERAGE_CHANNEL] == 129 and marked[0, 1, COVERAGE_CHANNEL] == 90
    assert np.all(marked[1] == 128) and marked[0, 0, 5] == 140


def test_cpu_and_shader_skinning_draw_the_same_body(body_model, still_pose):
    shape = body_model.default_shape()
    q = quantize_texture(sinusoid_texture(16, 128, seed=4))
    skel = skeleton_from_body_model(body_model, shape)
    mesh = skinned_mesh_from_body_model(body_model, shape)
    rot, tr = still_pose
    ctx = create_headless_context()
    try:
        out = []
        for cpu in (True, False):
            nr = NeuralRasterizer(ctx, mesh, q, 160, 160, skel.num_bones, cpu_skinning=cpu)
            nr.draw(skel.bone_transforms(rot, tr), front_camera(160, yaw_deg=-50))
            out.append(nr.read().astype(np.int32))
            nr.release()
    finally:
        ctx.release()
    covered = out[1][..., 0] != 128
    differ = (out[0] != out[1]).any(-1)
    assert covered.sum() > 1000
    assert differ[covered].mean() < 0.01  # float rounding moves a few edge pixels, nothing else
    assert np.array_equal(out[0][..., 0] != 128, covered) or (out[0][..., 0] != 128)[~covered].mean() < 0.002
