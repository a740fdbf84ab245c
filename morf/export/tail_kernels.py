"""The renderer's full-resolution tail as two compiled loops (numba): one pass over the pixels
instead of the ~35 full-resolution onnxruntime ops it replaces (see :mod:`morf.export.compiled_tail`
for the function and the contract).

Importing this module imports numba; the loops compile on first use and are cached on disk
(``cache=True``: beside this file, or numba's user cache when that is read-only).
"""

from __future__ import annotations

import numba as nb
import numpy as np

# sigmoid by table: logits clamped to [-16, 16] in steps of 1/128, linear in between (error below
# 1e-6, far under one level of 8 bits); below -16 the mask is under 1.2e-7 and the pixel is the
# background alone
SIGMOID_LO = -16.0
SIGMOID_STEPS_PER_UNIT = 128
SIGMOID_TABLE_SIZE = 32 * SIGMOID_STEPS_PER_UNIT + 2


def sigmoid_table() -> np.ndarray:
    t = SIGMOID_LO + np.arange(SIGMOID_TABLE_SIZE, dtype=np.float64) / SIGMOID_STEPS_PER_UNIT
    return (1.0 / (1.0 + np.exp(-t))).astype(np.float32)


@nb.njit(parallel=True, fastmath=True, cache=True, nogil=True)
def erode_rows(raster, channel, zero_point, margin, rows):
    """rows[y, x] = 1 where the pixels within ``margin`` along the row (clipped to the image) are all
    covered (byte ``channel`` of the NHWC raster is not ``zero_point``), else 0."""
    H, W = raster.shape[1], raster.shape[2]
    for y0 in nb.prange(H):
        y = np.int64(y0)
        last = -2 * margin - 2  # the last uncovered column seen, from the left
        for x in range(W):
            if raster[0, y, x, channel] == zero_point:
                last = x
            rows[y, x] = 0 if x - last <= margin else 1
        last = W + 2 * margin + 2  # from the right
        for x in range(W - 1, -1, -1):
            if raster[0, y, x, channel] == zero_point:
                last = x
            if last - x <= margin:
                rows[y, x] = 0


@nb.njit(parallel=True, fastmath=True, cache=True, nogil=True)
def shade(raster, head, fill, colour_scale, zero_point, channel, logit_scale, logit_offset, weight_min,
          margin, rows, background, table, out):
    """The tail, one row of output pixels per task; see :func:`morf.export.compiled_tail.reference_tail`
    for the same function in numpy. ``background``: (3, 1|H, 1|W) float32, 0-255."""
    H, W = raster.shape[1], raster.shape[2]
    h, w = head.shape[2], head.shape[3]
    zp = np.float32(zero_point)
    unit = np.float32(1.0 / 255.0)
    steps = np.float32(SIGMOID_STEPS_PER_UNIT)
    lo = np.float32(SIGMOID_LO)
    for y0 in nb.prange(H):
        y = np.int64(y0)
        # 2x bilinear upsampling, half-pixel centres, edges clamped (onnxruntime's Resize and
        # torch's interpolate with align_corners=False): output row y reads rows ya, yb
        ya = (y >> 1) if y & 1 else (y >> 1) - 1
        yb = min(ya + 1, h - 1)
        ya = max(ya, 0)
        wb = np.float32(0.25) if y & 1 else np.float32(0.75)
        wa = np.float32(1.0) - wb
        # the 8 source channels interpolated down the column, padded by one clamped sample each side
        vert = np.empty((8, w + 2), np.float32)
        for ch in range(4):
            for j in range(w):
                vert[ch, j + 1] = wa * head[0, ch, ya, j] + wb * head[0, ch, yb, j]
                vert[4 + ch, j + 1] = wa * fill[0, ch, ya, j] + wb * fill[0, ch, yb, j]
        for ch in range(8):
            vert[ch, 0] = vert[ch, 1]
            vert[ch, w + 1] = vert[ch, w]
        inside = np.zeros(W, np.uint8)
        if margin > 0:
            inside[:] = 1
            for yy in range(max(0, y - margin), min(H - 1, y + margin) + 1):
                for x in range(W):
                    inside[x] &= rows[yy, x]
        by = y if background.shape[1] > 1 else 0
        for x0 in range(W):
            x = np.int64(x0)
            bx = x if background.shape[2] > 1 else 0
            j = (x >> 1) + 1  # the padded index of the source column under x
            if x & 1:
                ia, ib, ua, ub = j, j + 1, np.float32(0.75), np.float32(0.25)
            else:
                ia, ib, ua, ub = j - 1, j, np.float32(0.25), np.float32(0.75)
            if inside[x]:
                mask = np.float32(1.0)
            else:
                t = ((ua * vert[3, ia] + ub * vert[3, ib]) * logit_scale + logit_offset - lo) * steps
                if t < np.float32(0.0):  # logit below -16: the background alone
                    for ch in range(3):
                        v = np.rint(background[ch, by, bx] * unit * np.float32(255.0))
                        out[y, x, ch] = np.uint8(min(max(v, np.float32(0.0)), np.float32(255.0)))
                    continue
                t = min(t, np.float32(SIGMOID_TABLE_SIZE - 2))
                i0 = np.int64(t)
                mask = table[i0] + (t - np.float32(i0)) * (table[i0 + 1] - table[i0])
            if raster[0, y, x, channel] != zero_point:  # covered: the texture's own colour, no fill
                q = np.float32(0.0)
            else:
                q = np.float32(1.0) / max(ua * vert[7, ia] + ub * vert[7, ib], weight_min)
            for ch in range(3):
                fill_c = ua * vert[4 + ch, ia] + ub * vert[4 + ch, ib]
                res = ua * vert[ch, ia] + ub * vert[ch, ib]
                tex = (np.float32(raster[0, y, x, ch]) - zp) * colour_scale[ch]
                col = (res + tex + fill_c * q) * mask + (np.float32(1.0) - mask) * background[ch, by, bx] * unit
                v = np.rint(col * np.float32(255.0))
                out[y, x, ch] = np.uint8(min(max(v, np.float32(0.0)), np.float32(255.0)))


@nb.njit(parallel=True, fastmath=True, cache=True, nogil=True)
def head_stage(low, skip, skip_scale, skip_zero_point, alpha, weight, bias, out):
    """The half-resolution head's last layers: ``out = weight @ leaky_relu(up(low) + (skip - zp) *
    scale) + bias`` per pixel, ``up`` as in :func:`shade` (2x, half-pixel centres, edges clamped).
    low: (1, C, h, w) float32; skip: (1, C, 2h, 2w) uint8 or float32; weight: (K, C); out: (1, K, 2h, 2w).
    Each row is done plane by plane (even and odd output columns read fixed taps), so the inner
    loops run over contiguous columns and vectorise."""
    C, h, w = low.shape[1], low.shape[2], low.shape[3]
    H, W = skip.shape[2], skip.shape[3]
    K = weight.shape[0]
    zp = np.float32(skip_zero_point)
    q, t = np.float32(0.25), np.float32(0.75)
    for y0 in nb.prange(H):
        y = np.int64(y0)
        ya = (y >> 1) if y & 1 else (y >> 1) - 1
        yb = min(ya + 1, h - 1)
        ya = max(ya, 0)
        wb = q if y & 1 else t
        wa = np.float32(1.0) - wb
        vert = np.empty(w + 2, np.float32)
        row = np.empty((C, W), np.float32)
        for c in range(C):
            for j in range(w):
                vert[j + 1] = wa * low[0, c, ya, j] + wb * low[0, c, yb, j]
            vert[0] = vert[1]
            vert[w + 1] = vert[w]
            for j in range(w):
                row[c, 2 * j] = q * vert[j] + t * vert[j + 1]
                row[c, 2 * j + 1] = t * vert[j + 1] + q * vert[j + 2]
            for x in range(W):
                v = row[c, x] + (np.float32(skip[0, c, y, x]) - zp) * skip_scale
                row[c, x] = v if v > np.float32(0.0) else v * alpha
        for k in range(K):
            for x in range(W):
                out[0, k, y, x] = bias[k]
            for c in range(C):
                wkc = weight[k, c]
                for x in range(W):
                    out[0, k, y, x] += wkc * row[c, x]
