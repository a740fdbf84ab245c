"""What the training path samples for a posed body: the reference both rasterizers are held to."""

from __future__ import annotations

import numpy as np
import torch

from morf.avatar.texture import sample_texture
from morf.body import BodyPose
from morf.body.render_mesh import render_mesh_for
from morf.raster import rasterize_uv


def training_raster_bytes(body_model, shape, q, rot: np.ndarray, tr: np.ndarray, camera):
    """(16, H, W) int32 bytes ``round(grid_sample(dequantised texture, uv) / scale + 128)`` and the
    (H, W) coverage of ``rasterize_uv``, for the body posed by ``rot``, ``tr``."""
    with torch.no_grad():
        verts = body_model(BodyPose(torch.from_numpy(rot)[None], torch.from_numpy(tr)[None]), shape).vertices
    rm = render_mesh_for(body_model)
    rast = rasterize_uv(rm.gather(verts)[0], rm, camera)
    feat = sample_texture(torch.from_numpy(q.dequantize()), torch.from_numpy(rast.uv)[None],
                          torch.from_numpy(rast.mask)[None])[0].numpy()
    return np.rint(feat / q.scales[:, None, None] + 128).astype(np.int32), rast.mask
