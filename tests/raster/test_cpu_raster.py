"""The CPU neural rasterization (numba) against the training path and against GL."""

import numpy as np
import pytest

from morf.errors import InputError
from morf.export.export_avatar import skinned_mesh_from_body_model
from morf.export.skeleton import skeleton_from_body_model
from morf.raster.camera_paths import front_camera
from morf.raster.cpu_raster import CpuNeuralRasterizer
from morf.raster.gl_context import create_headless_context
from morf.raster.neural_raster import NeuralRasterizer
from morf.raster.texture_quant import quantize_texture, sinusoid_texture
from raster_reference import training_raster_bytes

pytestmark = pytest.mark.gl


@pytest.fixture()
def gl_ctx():
    ctx = create_headless_context()
    yield ctx
    ctx.release()


@pytest.fixture()
def body(body_model):
    shape = body_model.default_shape()
    return (body_model, shape, skeleton_from_body_model(body_model, shape),
            skinned_mesh_from_body_model(body_model, shape))


def test_cpu_raster_matches_torch_sampling(body, still_pose):
    model, shape, skel, mesh = body
    q = quantize_texture(sinusoid_texture(16, 128, seed=2))
    cam = front_camera(128, yaw_deg=30)
    rot, tr = still_pose
    nr = CpuNeuralRasterizer(None, mesh, q, 128, 128, skel.num_bones)
    nr.draw(skel.bone_transforms(rot, tr), cam)
    cpu = nr.read().transpose(2, 0, 1).astype(np.int32)
    nr.release()
    ref, covered = training_raster_bytes(model, shape, q, rot, tr, cam)
    diff = np.abs(cpu - ref).max(axis=0)
    assert covered.sum() > 800
    assert (diff[covered] <= 1).mean() > 0.995  # float rounding of the filter weights: at most 1 LSB
    assert (diff[~covered] == 0).mean() > 0.99  # background is exactly the zero point
    assert ((cpu[0] != 128) == covered).mean() > 0.995  # the coverage byte marks the body


def test_cpu_raster_draws_what_gl_draws(body, still_pose, gl_ctx):
    _, _, skel, mesh = body
    q = quantize_texture(sinusoid_texture(16, 128, seed=4))
    rot, tr = still_pose
    gl_r = NeuralRasterizer(gl_ctx, mesh, q, 160, 160, skel.num_bones)
    cpu_r = CpuNeuralRasterizer(gl_ctx, mesh, q, 160, 160, skel.num_bones)
    for yaw in (-50, 0, 90, 180):
        cam = front_camera(160, yaw_deg=yaw)
        gl_r.draw(skel.bone_transforms(rot, tr), cam)
        cpu_r.draw(skel.bone_transforms(rot, tr), cam)
        a, b = gl_r.read().astype(np.int32), cpu_r.read().astype(np.int32)
        covered = a[..., 0] != 128
        assert covered.sum() > 500
        assert ((b[..., 0] != 128) != covered).sum() <= 4  # edge pixels at most
        both = covered & (b[..., 0] != 128)
        assert (np.abs(a - b).max(-1)[both] <= 1).mean() > 0.995
    gl_r.release()
    cpu_r.release()


def _fresh(mesh, q, skel, pose, cam) -> np.ndarray:
    nr = CpuNeuralRasterizer(None, mesh, q, cam.width, cam.height, skel.num_bones)
    nr.draw(skel.bone_transforms(*pose), cam)
    return nr.read()


def test_buffers_are_reused_without_leftovers_of_earlier_frames(body, still_pose):
    """Only the body's box is written: each buffer's last box is cleared before the next frame,
    and a buffer it has not filled before is cleared whole."""
    _, _, skel, mesh = body
    q = quantize_texture(sinusoid_texture(16, 64, seed=1))
    rot, tr = still_pose
    nr = CpuNeuralRasterizer(None, mesh, q, 96, 96, skel.num_bones)
    buffers = [np.full((1, 96, 96, 16), 7, np.uint8), np.zeros((1, 96, 96, 16), np.uint8)]  # garbage at first
    poses = [(rot, tr), (rot * 0, tr + np.float32([0.3, 0.1, 0])), (rot, tr - np.float32([0.3, 0, 0])), (rot, tr)]
    for i, pose in enumerate(poses):
        cam = front_camera(96, yaw_deg=40 * i)
        nr.draw(skel.bone_transforms(*pose), cam)
        assert np.array_equal(nr.read(buffers[i % 2])[0], _fresh(mesh, q, skel, pose, cam))


def test_a_camera_inside_the_depth_range_limits_hands_the_frame_to_gl(body, still_pose, gl_ctx):
    """A vertex before the near plane: GL clips, the loops do not, so GL draws that frame; the
    next frame into the same buffer, by the loops again, leaves nothing of it."""
    _, _, skel, mesh = body
    q = quantize_texture(sinusoid_texture(16, 64, seed=3))
    rot, tr = still_pose
    close, far = front_camera(96, distance=0.3), front_camera(96)
    gl_r = NeuralRasterizer(gl_ctx, mesh, q, 96, 96, skel.num_bones)
    cpu_r = CpuNeuralRasterizer(gl_ctx, mesh, q, 96, 96, skel.num_bones)
    buffer = np.empty((96, 96, 16), np.uint8)
    gl_r.draw(skel.bone_transforms(rot, tr), close)
    cpu_r.draw(skel.bone_transforms(rot, tr), close)
    assert cpu_r._by_gl
    assert np.array_equal(gl_r.read(), cpu_r.read(buffer))
    cpu_r.draw(skel.bone_transforms(rot, tr), far)
    assert not cpu_r._by_gl
    assert np.array_equal(cpu_r.read(buffer), _fresh(mesh, q, skel, (rot, tr), far))
    gl_r.release()
    cpu_r.release()


def test_the_player_rasterizes_on_the_cpu_under_software_gl(monkeypatch, gl_ctx):
    from morf.playback.player import choose_raster

    assert choose_raster("auto", gl_ctx) == "cpu"  # llvmpipe here
    assert choose_raster("gl", gl_ctx) == "gl"
    monkeypatch.setenv("MORF_RASTER", "gl")
    assert choose_raster("auto", gl_ctx) == "gl"
    with pytest.raises(InputError, match="raster must be one of"):
        choose_raster("vulkan", gl_ctx)
