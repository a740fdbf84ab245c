"""The glTF base-colour texture: what the trained avatar's renderer shows, baked into the UV atlas.

How it is baked: the body (dressed by the clothing offsets the avatar trained with, as the glTF's
mesh is) in the neutral A-pose (zero pose, the pose the neural texture was
baked for) is rendered by the trained renderer (fp32, torch) from a ring of cameras around it at
eye level plus rings above and below, each view framed on the body as the training crops were
(the person's square plus a margin, at the training resolution, so the renderer sees the scale it
learned). The renders, un-premultiplied where the renderer's mask says "person", are then
projected into the atlas exactly as the no-learning floor projects training frames
(:func:`morf.train.floor_texture.floor_texture`: per texel the mean colour of the pixels that see
it, facing the camera; texels no view sees are inpainted over the UV islands; islands grown a few
texels). Finally every texel outside the islands takes the colour of the nearest island
(:func:`morf.avatar.renderer.push_pull_fill`), so a viewer's mipmaps never blend in black.

The view-dependent and pose-dependent parts of the neural renderer cannot live in a static
colour texture; the glTF references the neural texture and the ONNX renderer for players that
can run them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from morf.camera import PinholeCamera
from morf.train.frames import FrameSet


@dataclass(frozen=True)
class BakeConfig:
    """Views and texture of the base-colour bake."""

    ring_views: int = 8  # cameras around the body at eye level
    extra_rings: tuple[tuple[float, int], ...] = ((40.0, 4), (-30.0, 4))  # (elevation degrees, views)
    fov_deg: float = 30.0  # vertical field of view before framing (sets the perspective, not the scale)
    distance: float = 3.0  # camera distance from the body's centre, metres
    margin: float = 0.08  # space around the body in each view, as the training crops (morf.train.data)
    resolution: int | None = None  # render side in pixels (None: the run's training resolution)
    texture_size: int | None = None  # texture side (None: the floor's rule, matched to the renders' texel density)
    min_facing: float = 0.3  # pixels whose surface is more oblique than this |cos| are not projected
    dilate: int = 4  # texels the islands are grown before the background fill


@dataclass(frozen=True)
class BakedColour:
    """A baked base-colour texture.

    Fields:
        rgb: (S, S, 3) uint8, row 0 = v 1 (the top, glTF's t = 0).
        seen: (S, S) bool texels that some view saw; covered: (S, S) bool texels of the UV islands.
        views: the renders it was projected from (images, masks, UVs, facing), for checks.
        cameras: one camera per view.
    """

    rgb: np.ndarray
    seen: np.ndarray
    covered: np.ndarray
    views: FrameSet
    cameras: list

    @property
    def seen_share(self) -> float:
        return float((self.seen & self.covered).sum() / max(self.covered.sum(), 1))


def view_directions(cfg: BakeConfig) -> list[tuple[float, float]]:
    """(azimuth, elevation) in degrees of every bake view; azimuth 0 looks at the body's front."""
    out = [(360.0 * i / cfg.ring_views, 0.0) for i in range(cfg.ring_views)]
    for elevation, n in cfg.extra_rings:
        out += [(360.0 * (i + 0.5) / n, elevation) for i in range(n)]
    return out


def framed_camera(vertices: np.ndarray, azimuth: float, elevation: float, resolution: int,
                  cfg: BakeConfig) -> PinholeCamera:
    """A ``resolution``-square camera looking at the body from (azimuth, elevation), framed on it.

    Anny axes: Z up, the body faces -Y; azimuth turns counter-clockwise seen from above.
    """
    from morf.train.data import crop_camera

    centre = 0.5 * (vertices.min(0) + vertices.max(0))
    a, e = math.radians(azimuth), math.radians(elevation)
    eye = centre + cfg.distance * np.array([math.sin(a) * math.cos(e), -math.cos(a) * math.cos(e), math.sin(e)])
    cam = PinholeCamera.look_at(resolution, resolution, cfg.fov_deg, eye, centre)
    xc = vertices @ cam.R.T + cam.t
    px = np.stack([cam.fx * xc[:, 0] / xc[:, 2] + cam.cx, cam.fy * xc[:, 1] / xc[:, 2] + cam.cy], 1)
    lo, hi = px.min(0), px.max(0)
    side = float((hi - lo).max()) * (1 + 2 * cfg.margin)
    mid = 0.5 * (lo + hi)
    return crop_camera(cam, mid[0] - side / 2, mid[1] - side / 2, side, resolution)


@torch.no_grad()
def render_bake_views(trained, mesh, vertices: np.ndarray, cameras: list) -> FrameSet:
    """Render the trained avatar on a posed render mesh from each camera.

    Args:
        trained: :class:`morf.train.trained_avatar.TrainedAvatar`; mesh: the render mesh
            (:class:`morf.body.render_mesh.RenderMesh`); vertices: (Vr, 3) its posed vertices.
    Returns:
        a FrameSet: images (N, H, W, 3) uint8 = the renders un-premultiplied (0 off the person),
        masks = renderer mask > 0.5, UVs / coverage / facing of the rasterization.
    """
    from morf.raster import rasterize_uv
    from morf.train.data import facing_map

    images, masks, uvs, uv_masks, facings = [], [], [], [], []
    for cam in cameras:
        r = rasterize_uv(vertices, mesh, cam)
        rgb, mask = trained.render(torch.from_numpy(r.uv)[None], torch.from_numpy(r.mask)[None])
        m = mask[0, 0].numpy()
        colour = np.clip(rgb[0].permute(1, 2, 0).numpy() / np.maximum(m, 1e-3)[..., None], 0, 1)
        person = m > 0.5
        images.append(np.where(person[..., None], np.round(colour * 255), 0).astype(np.uint8))
        masks.append(person)
        uvs.append(r.uv)
        uv_masks.append(r.mask)
        facings.append(facing_map(vertices, mesh.faces, r.face_id, cam))
    n = len(cameras)
    return FrameSet.from_float(np.stack(images), np.stack(masks), np.stack(uvs), np.stack(uv_masks),
                               np.zeros((n, 1, 3), np.float32), np.stack(facings))


def neutral_vertices(model, shape: torch.Tensor, offsets: np.ndarray | None = None) -> np.ndarray:
    """(Vr, 3) render-mesh vertices of the zero (A-) pose at the origin, Anny axes; dressed by
    clothing ``offsets`` (V,) when given, so the bake sees the surface the renderer trained on."""
    from morf.train.data import posed_render_vertices

    J = len(model.bone_names)
    return posed_render_vertices(model, np.zeros((1, J, 3), np.float32), np.zeros((1, 3), np.float32),
                                 shape.detach().cpu().numpy().reshape(1, -1), offsets)[0]


def bake_base_colour(trained, model, cfg: BakeConfig = BakeConfig(), offsets: np.ndarray | None = None) -> BakedColour:
    """Bake the avatar's colour into a texture (see the module docstring).

    Args:
        trained: the TrainedAvatar (its renderer, texture, shape and training resolution are used).
        model: the body model it was trained with.
        offsets: (V,) clothing offsets it trained with (None: the naked body), as the glTF mesh's.
    """
    from morf.avatar.renderer import push_pull_fill
    from morf.avatar.spectral import body_uv_atlas
    from morf.body.render_mesh import render_mesh_for
    from morf.train.floor_texture import choose_floor_size, floor_texture

    mesh = render_mesh_for(model)
    verts = neutral_vertices(model, trained.shape, offsets)
    multiple = int(getattr(trained.renderer.cfg, "multiple", 1))
    res = cfg.resolution or int(trained.config.resolution)
    res = -(-res // multiple) * multiple
    cameras = [framed_camera(verts, a, e, res, cfg) for a, e in view_directions(cfg)]
    views = render_bake_views(trained, mesh, verts, cameras)
    size = cfg.texture_size or choose_floor_size(views, cfg.min_facing).size
    covered = body_uv_atlas(model, size, size).covered
    texture, seen = floor_texture(views, covered, cfg.dilate, cfg.min_facing)
    # The islands as floor_texture grew them (a grown texel that is exactly black counts as
    # background and is refilled from its equally dark neighbours: no harm).
    grown = covered | (texture[:3].sum(0) > 0)
    grown_t = torch.from_numpy(grown[None, None].astype(np.float32))
    rgb = torch.from_numpy(texture[None, :3]) * grown_t
    filled = push_pull_fill(rgb, grown_t, max(1, int(math.log2(size))))
    out = np.round(filled[0].permute(1, 2, 0).clamp(0, 1).numpy() * 255).astype(np.uint8)
    return BakedColour(rgb=out, seen=seen, covered=covered, views=views, cameras=cameras)
