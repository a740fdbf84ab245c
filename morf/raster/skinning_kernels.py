"""Linear blend skinning of the render mesh on the CPU (numba), for the GL rasterizer: llvmpipe
runs vertex shaders on one thread, and the 8-bone skinning shader took about 2 ms of a 640x640
frame on a 2-core Intel Xeon; this loop takes about 0.12 ms on one thread
(``morf.raster.neural_raster``). It runs serially, outside numba's thread pool, so the GL
thread never waits on the renderer's compiled tail (which uses that pool) in pipelined playback.

Importing this module imports numba; the loop compiles on first use and is cached on disk.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(fastmath=True, cache=True, nogil=True)
def skin(rest, bone_indices, bone_weights, transforms, out):
    """out[v] = sum_k w[v, k] * (T[b[v, k]] @ [rest[v], 1])[:3] (morf.body.lbs.linear_blend_skinning
    with top-k weights). rest, out: (V, 3) float32; bone_indices (V, K) int32; bone_weights (V, K)
    float32; transforms (J, 4, 4) float32."""
    V, K = bone_indices.shape
    for v in range(V):
        x, y, z = rest[v, 0], rest[v, 1], rest[v, 2]
        ox = oy = oz = np.float32(0.0)
        for k in range(K):
            w = bone_weights[v, k]
            if w == np.float32(0.0):
                continue
            t = transforms[bone_indices[v, k]]
            ox += w * (t[0, 0] * x + t[0, 1] * y + t[0, 2] * z + t[0, 3])
            oy += w * (t[1, 0] * x + t[1, 1] * y + t[1, 2] * z + t[1, 3])
            oz += w * (t[2, 0] * x + t[2, 1] * y + t[2, 2] * z + t[2, 3])
        out[v, 0] = ox
        out[v, 1] = oy
        out[v, 2] = oz
