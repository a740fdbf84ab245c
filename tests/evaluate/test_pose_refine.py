"""Test-time pose refinement (``morf eval --refine-poses``): the differentiable UVs equal the GL
rasterizer's, and a known texture recovers a perturbed pose."""

from types import SimpleNamespace

import numpy as np
import pytest
import torch

pytestmark = [pytest.mark.gl]


def _body(J, rot_root=(0.0, 0.0, 0.0), transl=(0.0, 0.0, 0.0)):
    rot = np.zeros((1, J, 3), np.float32)
    rot[0, 0] = rot_root
    return rot, np.asarray([transl], np.float32)


def _pattern_texture(side: int = 64) -> torch.Tensor:
    """Smooth colour waves over the UV square (RGB) and a constant coverage channel."""
    v, u = torch.meshgrid(torch.linspace(0, 1, side), torch.linspace(0, 1, side), indexing="ij")
    rgb = torch.stack([0.5 + 0.4 * torch.sin(2 * np.pi * 5 * u), 0.5 + 0.4 * torch.sin(2 * np.pi * 4 * v),
                       0.5 + 0.4 * torch.cos(2 * np.pi * 3 * (u + v))])
    return torch.cat([rgb, torch.ones(1, side, side)])


def _frames(body_model, camera, avatar, rot, tr, shape, colour):
    """A FrameSet whose images are ``avatar`` rendered in (rot, tr): the truth to recover."""
    from morf.avatar.metrics import composite_over
    from morf.avatar.model import render_with_texture
    from morf.train.data import rasterize_frames
    from morf.train.frames import FrameSet

    uv, uvm, _ = next(rasterize_frames(body_model, rot, tr, shape, camera))
    rgb, alpha = render_with_texture(avatar.renderer, avatar.texture, torch.from_numpy(uv), torch.from_numpy(uvm))
    img = composite_over(rgb, alpha, colour)
    img = (img.permute(0, 2, 3, 1).numpy() * 255 + 0.5).astype(np.uint8)
    return FrameSet.from_float(img, uvm, uv, uvm, rot)


def test_uvs_match_the_gl_rasterizer(gl, body_model):
    from morf.body import BodyPose
    from morf.body.render_mesh import render_mesh_for
    from morf.evaluate.pose_refine import interpolate_uv
    from morf.raster import rasterize_uv_batch
    from morf.raster.camera_paths import front_camera

    cam = front_camera(96, center=(0.0, -0.3, 0.0))
    J = len(body_model.bone_names)
    rot, tr = _body(J, (0.0, 0.6, 0.0))
    shape = body_model.default_shape().reshape(1, -1)
    rm = render_mesh_for(body_model)
    v = rm.gather(body_model(BodyPose(torch.from_numpy(rot), torch.from_numpy(tr)), shape).vertices).detach()
    r = rasterize_uv_batch(v.numpy(), rm, cam)
    uv = interpolate_uv(v, torch.as_tensor(r.face_id).long(), torch.as_tensor(rm.faces).long(),
                        torch.as_tensor(rm.uvs), cam).numpy()
    covered = r.face_id >= 0
    assert covered.sum() > 500
    assert np.abs(uv[covered] - r.uv[covered]).max() < 1e-4
    assert np.all(uv[~covered] == 0)


def _truth(body_model, side: int):
    """A frozen avatar (the pattern texture, passed through) and one frame of it rendered in a
    known pose: (camera, shape, avatar, backdrop colour, frames, true rotvecs, true translation)."""
    from morf.avatar.passthrough import PassthroughRenderer
    from morf.raster.camera_paths import front_camera

    cam = front_camera(side, center=(0.0, -0.3, 0.0))
    shape = body_model.default_shape().reshape(1, -1).numpy()
    avatar = SimpleNamespace(renderer=PassthroughRenderer(), texture=_pattern_texture())
    colour = torch.tensor([0.2, 0.3, 0.4])
    true_rot, true_tr = _body(len(body_model.bone_names), (0.0, 0.5, 0.0))
    frames = _frames(body_model, cam, avatar, true_rot, true_tr, shape, colour)
    return cam, shape, avatar, colour, frames, true_rot, true_tr


def test_a_known_texture_recovers_a_perturbed_pose(gl, body_model):
    from morf.evaluate.pose_refine import RefineConfig, refine_poses

    cam, shape, avatar, colour, frames, true_rot, true_tr = _truth(body_model, 96)
    start_rot, start_tr = _body(len(body_model.bone_names), (0.0, 0.5 + np.radians(5), 0.0), (0.015, 0.0, 0.0))
    res = refine_poses(avatar, body_model, frames, start_rot, start_tr, shape, cam, colour,
                       RefineConfig(steps=40, batch=1))

    def vertex_error_mm(rot, tr):
        from morf.body import BodyPose

        def verts(r, t):
            return body_model(BodyPose(torch.from_numpy(r), torch.from_numpy(t)), torch.from_numpy(shape)).vertices

        return float((verts(rot, tr) - verts(true_rot, true_tr)).norm(dim=-1).mean()) * 1000

    start = vertex_error_mm(start_rot, start_tr)
    assert start > 20  # a few pixels at this camera
    assert res.loss_after < 0.5 * res.loss_before
    assert vertex_error_mm(res.rotvecs, res.transl) < 0.4 * start


def test_only_the_named_bones_turn_besides_the_root(gl, body_model):
    from morf.evaluate.pose_refine import RefineConfig, refine_poses

    cam, shape, avatar, colour, frames, _, _ = _truth(body_model, 64)
    start_rot, start_tr = _body(len(body_model.bone_names), (0.0, 0.55, 0.0))
    start_rot[:, body_model.bone_index("lowerarm01.L")] = (0.0, 0.0, 0.3)
    turned = {}
    for bones in ((), ("lowerarm01.L",)):
        res = refine_poses(avatar, body_model, frames, start_rot, start_tr, shape, cam, colour,
                           RefineConfig(steps=8, batch=1, bones=bones, bone_lr=0.01))
        moved = np.abs(res.rotvecs - start_rot).max(axis=(0, 2)) > 1e-6
        turned[bones] = {body_model.bone_names[j] for j in np.flatnonzero(moved)}
    assert turned[()] <= {body_model.bone_names[0]}
    assert "lowerarm01.L" in turned[("lowerarm01.L",)] and turned[("lowerarm01.L",)] <= {
        body_model.bone_names[0], "lowerarm01.L"}
