"""Test-time pose refinement: each evaluated frame's body pose adjusted so that a frozen avatar's
render matches the real frame, before it is scored.

Held-out frames are posed by their fits and novel poses by the ground truth placed on the fitted
body, so part of every score is the fit's error, not the avatar's appearance. Monocular avatar
papers evaluated on People-Snapshot refine the test poses against the test images with the
avatar frozen (Anim-NeRF, InstantAvatar); ``morf eval --refine-poses`` does the same, with the
same settings for every run, the RGB floor included, and reports it as its own protocol.

The rasterizer is not differentiable, so the image's dependence on the pose comes through the
texture coordinates inside each triangle: the GL rasterization gives each pixel its triangle
(again after every step by default), and the perspective-correct barycentrics of the pixel
centre in the projected triangle are computed in torch from the posed vertices. The loss is L1
between the render and the frame, both composited over the capture's backdrop, summed over a
coarse-to-fine pyramid, with an L2 penalty on the pose change.

The body is the one the avatar trained on: dressed by its clothing offsets when it has them
(:func:`morf.fitting.offsets.dressed_vertices`), so a loose hem or a hood is drawn, and the
pose is not pulled to fit the naked body inside the clothes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch
import torch.nn.functional as F

from morf.camera import PinholeCamera, project_points
from morf.train.frames import FrameSet, pack_uv


@dataclass(frozen=True)
class RefineConfig:
    """How the poses are refined: the optimisation, the bones it may turn, the loss."""

    steps: int = 40  # Adam steps a frame
    lr: float = 0.004  # step size of the root (radians) and the translation (metres)
    batch: int = 4  # frames refined together
    # bones refined besides the root and the translation (e.g. the fitter's,
    # morf.fitting.params.FIT_BONES), at step size bone_lr; none by default
    bones: tuple[str, ...] = ()
    bone_lr: float = 0.001
    raster_every: int = 1  # steps between re-rasterizations (which triangle covers a pixel)
    prior: float = 0.05  # weight of the squared pose change (radians^2) and translation (metres^2, times 100)
    levels: int = 3  # pyramid levels of the loss (1: full resolution only)


@dataclass(frozen=True)
class RefinedPoses:
    """Fields: rotvecs (N, J, 3) and transl (N, 3) after refinement; loss_before / loss_after:
    the mean L1 of the composited render at full resolution, before and after; offsets: (V,)
    clothing offsets of the body they were refined on (None: the naked body), which
    :func:`reposed_frames` rasterizes again."""

    rotvecs: np.ndarray
    transl: np.ndarray
    loss_before: float
    loss_after: float
    offsets: np.ndarray | None = None


def _rotvec_compose(delta: torch.Tensor, rot: torch.Tensor) -> torch.Tensor:
    """Axis-angle of R(delta) @ R(rot), batched over leading axes."""
    from morf.body.rotations import axis_angle_to_matrix, matrix_to_axis_angle

    return matrix_to_axis_angle(axis_angle_to_matrix(delta) @ axis_angle_to_matrix(rot))


def interpolate_uv(verts: torch.Tensor, face_id: torch.Tensor, faces: torch.Tensor, uvs: torch.Tensor,
                   camera: PinholeCamera) -> torch.Tensor:
    """(B, Vr, 3) posed render vertices + (B, H, W) triangle per pixel (-1: none) -> (B, H, W, 2)
    UVs at the pixel centres, perspective-correct, differentiable in the vertices (zero where no
    triangle covers the pixel)."""
    B, H, W = face_id.shape
    cam_pts = camera.world_to_camera(verts)  # (B, Vr, 3)
    px = project_points(cam_pts, camera.fx, camera.fy, camera.cx, camera.cy)
    z = cam_pts[..., 2].clamp_min(1e-6)
    b_idx, y_idx, x_idx = torch.nonzero(face_id >= 0, as_tuple=True)
    tri = faces[face_id[b_idx, y_idx, x_idx]]  # (P, 3)
    p = px[b_idx[:, None], tri]  # (P, 3, 2)
    q = torch.stack([x_idx.to(px) + 0.5, y_idx.to(px) + 0.5], -1)  # pixel centres
    v0, v1 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    v2 = q - p[:, 0]
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    den = torch.where(den.abs() < 1e-9, torch.full_like(den, 1e-9), den)
    l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
    l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
    bary = torch.stack([1 - l1 - l2, l1, l2], -1)
    w = bary / z[b_idx[:, None], tri]  # perspective correction
    w = w / w.sum(-1, keepdim=True)
    uv_pix = (w[..., None] * uvs[tri]).sum(1)  # (P, 2)
    out = torch.zeros(B, H, W, 2, dtype=uv_pix.dtype)
    return out.index_put((b_idx, y_idx, x_idx), uv_pix)


def _pyramid_l1(pred: torch.Tensor, gt: torch.Tensor, levels: int) -> torch.Tensor:
    loss = (pred - gt).abs().mean()
    for _ in range(levels - 1):
        pred, gt = F.avg_pool2d(pred, 2), F.avg_pool2d(gt, 2)
        loss = loss + (pred - gt).abs().mean()
    return loss


def refine_poses(avatar, model, frames: FrameSet, rotvecs: np.ndarray, transl: np.ndarray, shape: np.ndarray,
                 camera: PinholeCamera, colour: torch.Tensor, cfg: RefineConfig = RefineConfig(),
                 offsets: np.ndarray | None = None) -> RefinedPoses:
    """Refine every frame's root orientation and translation (and ``cfg.bones``) against
    ``frames``' images composited over ``colour``, with ``avatar`` (texture and renderer) frozen:
    its renderer's parameters stop requiring gradients. ``camera`` is the camera ``frames`` were
    rasterized through; ``offsets`` (V,) the clothing offsets the avatar trained with
    (:func:`morf.train.data.clothing_offsets`; None: the naked body)."""
    from morf.avatar.metrics import composite_over
    from morf.body import BodyPose
    from morf.body.render_mesh import render_mesh_for
    from morf.fitting.offsets import dressed_vertices
    from morf.raster import rasterize_uv_batch

    rm = render_mesh_for(model)
    offsets_t = None if offsets is None else torch.as_tensor(np.asarray(offsets, np.float32))
    bone_ids = torch.as_tensor([model.bone_index(b) for b in cfg.bones if model.bone_index(b) > 0], dtype=torch.long)
    faces = torch.as_tensor(rm.faces, dtype=torch.long)
    uvs = torch.as_tensor(rm.uvs, dtype=torch.float32)
    shape_t = torch.as_tensor(np.asarray(shape, np.float32).reshape(1, -1))
    for p in avatar.renderer.parameters():
        p.requires_grad_(False)
    out_rot, out_tr = np.array(rotvecs, np.float32, copy=True), np.array(transl, np.float32, copy=True)
    before, after = [], []
    N = frames.num_frames
    for s in range(0, N, cfg.batch):
        idx = list(range(s, min(s + cfg.batch, N)))
        b = frames.batch(idx)
        gt = composite_over(b.image * b.mask, b.mask, colour)
        rot0 = torch.as_tensor(out_rot[idx])
        tr0 = torch.as_tensor(out_tr[idx])
        d_root = torch.zeros(len(idx), 3, requires_grad=True)
        d_bones = torch.zeros(len(idx), len(bone_ids), 3, requires_grad=True)
        d_tr = torch.zeros_like(tr0, requires_grad=True)
        opt = torch.optim.Adam([{"params": [d_root, d_tr]}, {"params": [d_bones], "lr": cfg.bone_lr}], lr=cfg.lr)
        face_id = None

        def posed(d_root, d_bones, d_tr):
            rest = rot0[:, 1:].index_add(1, bone_ids - 1, d_bones)
            rot = torch.cat([_rotvec_compose(d_root[:, None], rot0[:, :1]), rest], 1)
            out = model(BodyPose(rot, tr0 + d_tr), shape_t)
            return rm.gather(dressed_vertices(model, out, shape_t, offsets_t)), rot

        # an avatar with view colours: each frame in the colour of its given pose
        textures = [avatar.texture_for(out_rot[i]) if hasattr(avatar, "texture_for") else avatar.texture
                    for i in idx]

        def image(verts, face_id):
            uv = interpolate_uv(verts, face_id, faces, uvs, camera)
            return composite_over(*_render_each(avatar.renderer, textures, uv, face_id >= 0), colour)

        best = None
        for step in range(cfg.steps + 1):
            verts, rot = posed(d_root, d_bones, d_tr)
            if face_id is None or step % cfg.raster_every == 0 or step == cfg.steps:
                face_id = torch.as_tensor(rasterize_uv_batch(verts.detach().numpy(), rm, camera).face_id).long()
            pred = image(verts, face_id)
            full = (pred - gt).abs().mean(dim=(1, 2, 3)).detach()
            if step == 0:
                before.append(full)
                best = (full.clone(), rot.detach().clone(), (tr0 + d_tr).detach().clone())
            else:  # keep each frame's best pose seen (Adam may overshoot)
                better = full < best[0]
                best = (torch.where(better, full, best[0]),
                        torch.where(better[:, None, None], rot.detach(), best[1]),
                        torch.where(better[:, None], (tr0 + d_tr).detach(), best[2]))
            if step == cfg.steps:
                break
            change = d_root.pow(2).sum() + d_bones.pow(2).sum() + 100 * d_tr.pow(2).sum()
            loss = _pyramid_l1(pred, gt, cfg.levels) + cfg.prior * change / len(idx)
            opt.zero_grad()
            loss.backward()
            opt.step()
        after.append(best[0])
        out_rot[idx], out_tr[idx] = best[1].numpy(), best[2].numpy()
    return RefinedPoses(out_rot, out_tr, float(torch.cat(before).mean()), float(torch.cat(after).mean()), offsets)


def reposed_frames(frames: FrameSet, model, refined: RefinedPoses, shape: np.ndarray,
                   camera: PinholeCamera) -> FrameSet:
    """``frames`` with their rasterization redone in the refined poses (images and masks kept), on
    the body they were refined on (dressed by ``refined.offsets`` when given)."""
    from morf.train.data import rasterize_frames

    uvs, uvms, facings = [], [], []
    for uv, uvm, fac in rasterize_frames(model, refined.rotvecs, refined.transl,
                                         np.asarray(shape, np.float32).reshape(1, -1), camera,
                                         offsets=refined.offsets):
        uvs.append(pack_uv(uv))
        uvms.append(uvm)
        facings.append(fac)
    return replace(frames, uv=np.concatenate(uvs), uv_mask=np.concatenate(uvms), facing=np.concatenate(facings),
                   rotvecs=refined.rotvecs.astype(np.float32))


def _render_each(renderer, textures: list, uv: torch.Tensor, covered: torch.Tensor):
    """(RGB, mask) of a batch whose frames each have their texture (one call when they share one)."""
    from morf.avatar.model import render_with_texture

    if all(t is textures[0] for t in textures):
        return render_with_texture(renderer, textures[0], uv, covered)
    outs = [render_with_texture(renderer, t, uv[j:j + 1], covered[j:j + 1]) for j, t in enumerate(textures)]
    return torch.cat([o[0] for o in outs]), torch.cat([o[1] for o in outs])
