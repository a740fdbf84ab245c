// Linear blend skinning of one render vertex on the CPU: the player's per-frame skinning
// (raster.js) and the person's box (bounds.js) turn the same rest vertices with the same eight
// bone weights, so both call this.

// out[o..o+2] = vertex v of rest (3 per vertex) skinned by rows (Float32Array(J * 12): the top
// three rows of each bone's skinning matrix) with its 8 weights and bone indices.
export function skinVertex(out, o, rows, rest, weights, bones, v) {
  const px = rest[3 * v], py = rest[3 * v + 1], pz = rest[3 * v + 2];
  let X = 0, Y = 0, Z = 0;
  for (let k = 8 * v, e = k + 8; k < e; k++) {
    const w = weights[k];
    if (w === 0) continue;
    const r = 12 * bones[k];
    X += w * (rows[r] * px + rows[r + 1] * py + rows[r + 2] * pz + rows[r + 3]);
    Y += w * (rows[r + 4] * px + rows[r + 5] * py + rows[r + 6] * pz + rows[r + 7]);
    Z += w * (rows[r + 8] * px + rows[r + 9] * py + rows[r + 10] * pz + rows[r + 11]);
  }
  out[o] = X; out[o + 1] = Y; out[o + 2] = Z;
}
