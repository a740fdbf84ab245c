"""The neural rasterization as numba loops, for playback where GL itself runs on the CPU.

Under Mesa's llvmpipe the draw of the 27 k-triangle body at 640 x 640 cost about 5 ms, most of
it triangle setup and binning on one thread (a fragment shader writing a constant took as long),
and the read-back 0.5 ms more. These loops do the same work straight into the renderer's input:
project the skinned vertices (:func:`project`), keep the nearest front-facing triangle at each
pixel centre (:func:`raster_ids`), then sample the 16-channel texture there (:func:`shade`);
:func:`draw_frame` and :func:`read_frame` chain them into the rasterizer's two calls.

The sampling is the GL shader's and the training's: perspective-correct texture coordinates,
bilinear filtering of the texture bytes with clamp-to-edge (``grid_sample``, ``align_corners=False``,
``padding_mode="border"``), rounded to a byte, the coverage byte moved off the zero point
(``neural_raster_fs.glsl``). Pixel centres and triangle edges follow GL's rules, so coverage
matches llvmpipe's to a pixel or two a frame.

Serial and ``nogil``: in pipelined playback they run beside the renderer's threads, as the
numba skinning loop does (:mod:`morf.raster.skinning_kernels`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from morf.raster.skinning_kernels import skin
from morf.raster.texture_quant import ZERO_POINT  # the byte of value 0: the background's


@nb.njit(cache=True, nogil=True)
def project(posed, view_proj, width, height, sx, sy, sz, iw):
    """Screen positions of the posed vertices: sx, sy in pixels (x right, y = image row down, as
    the GL projection flips y), sz = NDC depth, iw = 1 / clip w. Returns False when a vertex lies
    outside the depth range (before the near plane or behind the far one), where GL would clip
    and these loops do not; the caller then rasterizes with GL."""
    ok = True
    for v in range(posed.shape[0]):
        x, y, z = posed[v, 0], posed[v, 1], posed[v, 2]
        cx = view_proj[0, 0] * x + view_proj[0, 1] * y + view_proj[0, 2] * z + view_proj[0, 3]
        cy = view_proj[1, 0] * x + view_proj[1, 1] * y + view_proj[1, 2] * z + view_proj[1, 3]
        cz = view_proj[2, 0] * x + view_proj[2, 1] * y + view_proj[2, 2] * z + view_proj[2, 3]
        cw = view_proj[3, 0] * x + view_proj[3, 1] * y + view_proj[3, 2] * z + view_proj[3, 3]
        if not (cw > 1e-6 and -cw <= cz <= cw):
            ok = False
            cw = np.float32(1e-6)
        inv = np.float32(1.0) / cw
        sx[v] = (cx * inv + np.float32(1.0)) * np.float32(0.5) * width
        sy[v] = (cy * inv + np.float32(1.0)) * np.float32(0.5) * height
        sz[v] = cz * inv
        iw[v] = inv
    return ok


@nb.njit(cache=True, nogil=True)
def raster_ids(sx, sy, sz, faces, tri, depth, y_lo, y_hi, x_lo, x_hi):
    """tri[y, x] = the nearest front-facing triangle whose inside holds the pixel centre, for the
    rows y_lo..y_hi-1 and columns x_lo..x_hi-1 (tri -1 and depth +inf there beforehand). A front
    face is clockwise on the image (the mesh's counter-clockwise faces, seen through the y flip);
    back faces are culled as the GL draw culls them."""
    half = np.float32(0.5)
    for f in range(faces.shape[0]):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        x0, y0, x1, y1, x2, y2 = sx[a], sy[a], sx[b], sy[b], sx[c], sy[c]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if area >= 0:  # back facing or degenerate
            continue
        x1, y1, x2, y2 = x2, y2, x1, y1  # counter-clockwise from here on: all edge functions >= 0 inside
        b, c = c, b
        area = -area
        ymin = max(y_lo, int(np.ceil(min(y0, min(y1, y2)) - half)))
        ymax = min(y_hi - 1, int(np.floor(max(y0, max(y1, y2)) - half)))
        xmin = max(x_lo, int(np.ceil(min(x0, min(x1, x2)) - half)))
        xmax = min(x_hi - 1, int(np.floor(max(x0, max(x1, x2)) - half)))
        if ymin > ymax or xmin > xmax:
            continue
        # GL's top-left rule: a pixel centre on an edge belongs to the triangle only on a top edge
        # (horizontal, above) or a left edge; the bias makes the others exclusive
        bias0 = 0.0 if (y2 < y1) or (y2 == y1 and x2 < x1) else -1e-7
        bias1 = 0.0 if (y0 < y2) or (y0 == y2 and x0 < x2) else -1e-7
        bias2 = 0.0 if (y1 < y0) or (y1 == y0 and x1 < x0) else -1e-7
        inv_area = np.float32(1.0) / area
        z0, z1, z2 = sz[a], sz[b], sz[c]
        for py in range(ymin, ymax + 1):
            cy = np.float32(py) + half
            for px in range(xmin, xmax + 1):
                cx = np.float32(px) + half
                e0 = (x2 - x1) * (cy - y1) - (y2 - y1) * (cx - x1)
                e1 = (x0 - x2) * (cy - y2) - (y0 - y2) * (cx - x2)
                e2 = (x1 - x0) * (cy - y0) - (y1 - y0) * (cx - x0)
                if e0 + bias0 < 0 or e1 + bias1 < 0 or e2 + bias2 < 0:
                    continue
                z = (e0 * z0 + e1 * z1 + e2 * z2) * inv_area
                if z < depth[py, px]:
                    depth[py, px] = z
                    tri[py, px] = f


@nb.njit(fastmath=True, cache=True, nogil=True)
def shade(tri, sx, sy, iw, faces, uvs, texture, out, y_lo, y_hi, x_lo, x_hi):
    """out[y, x, :] = the texture bytes sampled at each covered pixel of the box (others left as
    they are). texture: (Ht, Wt, 16) uint8, row 0 = v 1; uvs: (V, 2) with v up."""
    ht, wt = texture.shape[0], texture.shape[1]
    f_w, f_h = np.float32(wt), np.float32(ht)
    half, one, zero = np.float32(0.5), np.float32(1.0), np.float32(0.0)
    for py in range(y_lo, y_hi):
        cy = np.float32(py) + half
        for px in range(x_lo, x_hi):
            f = tri[py, px]
            if f < 0:
                continue
            cx = np.float32(px) + half
            a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
            x0, y0, x1, y1, x2, y2 = sx[a], sy[a], sx[b], sy[b], sx[c], sy[c]
            p0 = ((x2 - x1) * (cy - y1) - (y2 - y1) * (cx - x1)) * iw[a]  # perspective-correct weights
            p1 = ((x0 - x2) * (cy - y2) - (y0 - y2) * (cx - x2)) * iw[b]
            p2 = ((x1 - x0) * (cy - y0) - (y1 - y0) * (cx - x0)) * iw[c]
            s = one / (p0 + p1 + p2)
            p0, p1, p2 = p0 * s, p1 * s, p2 * s
            u = p0 * uvs[a, 0] + p1 * uvs[b, 0] + p2 * uvs[c, 0]
            v = p0 * uvs[a, 1] + p1 * uvs[b, 1] + p2 * uvs[c, 1]
            tx = min(max(u * f_w - half, zero), f_w - one)  # texel centres at +0.5, clamped to the edge
            ty = min(max((one - v) * f_h - half, zero), f_h - one)
            ix = min(np.int32(tx), wt - 2)
            iy = min(np.int32(ty), ht - 2)
            fx = tx - np.float32(ix)
            fy = ty - np.float32(iy)
            w00, w01 = (one - fx) * (one - fy), fx * (one - fy)
            w10, w11 = (one - fx) * fy, fx * fy
            t00, t01, t10, t11 = texture[iy, ix], texture[iy, ix + 1], texture[iy + 1, ix], texture[iy + 1, ix + 1]
            o = out[py, px]
            for ch in range(16):
                o[ch] = np.uint8(w00 * np.float32(t00[ch]) + w01 * np.float32(t01[ch]) + w10 * np.float32(t10[ch])
                                 + w11 * np.float32(t11[ch]) + half)
            if o[0] == ZERO_POINT:  # the coverage mark (morf.raster.neural_raster.COVERAGE_CHANNEL)
                o[0] = ZERO_POINT + 1


@nb.njit(cache=True, nogil=True)
def draw_frame(rest, bone_indices, bone_weights, transforms, posed, view_proj, width, height, sx, sy, sz, iw,
               faces, tri, depth, box):
    """One frame's skinning, projection and triangle ids in a single call (one GIL round trip:
    in the studio the training thread holds the GIL much of the time). ``box`` (4 int32: y0, y1,
    x0, x1) holds the last drawn box on entry, whose ids are cleared, and this frame's on return
    (empty: y0 == y1). Returns False when GL has to draw the frame (see :func:`project`)."""
    skin(rest, bone_indices, bone_weights, transforms, posed)
    if not project(posed, view_proj, width, height, sx, sy, sz, iw):
        return False
    for y in range(box[0], box[1]):
        for x in range(box[2], box[3]):
            tri[y, x] = -1
            depth[y, x] = np.inf
    h, w = tri.shape
    x0 = max(0, int(np.floor(sx.min())) - 1)
    x1 = min(w, int(np.ceil(sx.max())) + 1)
    y0 = max(0, int(np.floor(sy.min())) - 1)
    y1 = min(h, int(np.ceil(sy.max())) + 1)
    if x0 >= x1 or y0 >= y1:
        x0 = x1 = y0 = y1 = 0
    box[0], box[1], box[2], box[3] = y0, y1, x0, x1
    if y0 < y1:
        raster_ids(sx, sy, sz, faces, tri, depth, y0, y1, x0, x1)
    return True


@nb.njit(cache=True, nogil=True)
def read_frame(tri, sx, sy, iw, faces, uvs, texture, out, clear_box, box):
    """The drawn frame into ``out`` (H, W, 16): the zero point over ``clear_box`` (what this buffer
    held before: its last box, or all of it), then the texture sampled over ``box``."""
    for y in range(clear_box[0], clear_box[1]):
        for x in range(clear_box[2], clear_box[3]):
            for ch in range(out.shape[2]):
                out[y, x, ch] = ZERO_POINT
    if box[0] < box[1]:
        shade(tri, sx, sy, iw, faces, uvs, texture, out, box[0], box[1], box[2], box[3])
