// The person's box on the image, before rasterizing: a subset of the render mesh skinned on the
// CPU with the frame's bone rows and projected with its camera. Everything after the raster (the
// read-back, the renderer, the tail) then runs on a window around that box instead of the whole
// frame: on this avatar at 640 x 640 the body covers about a tenth of the image, and off the body
// the renderer's mask is 0 (the background shows) beyond a few pixels (docs/web.md, "The person's window").

import { skinVertex } from './skinning.js';

const STRIDE = 3;  // every third render vertex: gaps of a few millimetres, far under the margin

export class BodyBox {
  // doc: avatar.json; mesh: mesh.bin (ArrayBuffer)
  constructor(doc, mesh) {
    const a = doc.mesh.arrays, n = a.rest_vertices.shape[0], k = Math.ceil(n / STRIDE);
    const rest = new Float32Array(mesh, a.rest_vertices.offset, n * 3);
    const weights = new Float32Array(mesh, a.bone_weights.offset, n * 8);
    const Index = a.bone_indices.type === 'uint16' ? Uint16Array : Uint8Array;
    const bones = new Index(mesh, a.bone_indices.offset, n * 8);
    this.count = k;
    this.rest = new Float32Array(3 * k);
    this.weights = new Float32Array(8 * k);
    this.bones = new Uint16Array(8 * k);
    this.point = new Float64Array(3);  // one skinned vertex at a time
    for (let i = 0, v = 0; v < n; i++, v += STRIDE) {
      this.rest.set(rest.subarray(3 * v, 3 * v + 3), 3 * i);
      this.weights.set(weights.subarray(8 * v, 8 * v + 8), 8 * i);
      this.bones.set(bones.subarray(8 * v, 8 * v + 8), 8 * i);
    }
  }

  // rows: Float32Array(J * 12), the top three rows of each skinning matrix; cam: pinhole
  // (fx, fy, cx, cy, R row-major, t). Returns [x0, y0, x1, y1] in pixels (rows top first), or
  // null when a vertex is at or behind the camera (the whole frame is then used). skinned: the
  // render mesh already skinned (Float32Array, 3 per vertex) at the vertices ``used`` (Uint32Array:
  // those the drawn faces use), which are then only projected, every STRIDE-th of them.
  box(rows, cam, skinned = null, used = null) {
    const { rest, weights, bones } = this, R = cam.R, t = cam.t, p = this.point;
    const count = skinned ? Math.ceil(used.length / STRIDE) : this.count;
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    for (let i = 0; i < count; i++) {
      if (skinned) {
        const v = 3 * used[STRIDE * i];
        p[0] = skinned[v]; p[1] = skinned[v + 1]; p[2] = skinned[v + 2];
      } else {
        skinVertex(p, 0, rows, rest, weights, bones, i);
      }
      const X = p[0], Y = p[1], Z = p[2];
      const zc = R[6] * X + R[7] * Y + R[8] * Z + t[2];
      if (!(zc > 1e-3)) return null;
      const u = (cam.fx * (R[0] * X + R[1] * Y + R[2] * Z + t[0])) / zc + cam.cx;
      const v = (cam.fy * (R[3] * X + R[4] * Y + R[5] * Z + t[1])) / zc + cam.cy;
      if (u < x0) x0 = u;
      if (u > x1) x1 = u;
      if (v < y0) y0 = v;
      if (v > y1) y1 = v;
    }
    return count ? [x0, y0, x1, y1] : null;
  }
}

// The window the renderer runs on: the box grown by `margin` pixels, its edges on the renderer's
// size multiple (the strided layers then sample the same pixels as on the whole frame), inside
// the frame. Its width and height change only when the box outgrows them, or after `patience`
// frames in which a smaller window would have done: every new shape costs the renderer a new
// session (its dimensions are fixed in it, so that onnxruntime folds the shape arithmetic).
export class CropWindow {
  constructor(multiple, margin, patience = 30) {
    this.g = multiple;
    this.margin = margin;
    this.patience = patience;
    this.w = 0; this.h = 0; this.smaller = 0;
  }

  // box: [x0, y0, x1, y1] or null; size: the frame's side. Returns {x, y, w, h} (pixels, rows top first).
  choose(box, size) {
    if (!box || this.margin < 0) return { x: 0, y: 0, w: size, h: size };
    const g = this.g, m = this.margin;
    const span = (lo, hi) => {  // the aligned interval covering [lo - m, hi + m], clipped to the frame
      const a = Math.min(Math.max(Math.floor((lo - m) / g) * g, 0), size - g);
      const b = Math.max(Math.min(Math.ceil((hi + 1 + m) / g) * g, size), a + g);
      return [a, b];
    };
    const [xa, xb] = span(box[0], box[2]), [ya, yb] = span(box[1], box[3]);
    const needW = xb - xa, needH = yb - ya;
    if (this.w > size || this.h > size) { this.w = 0; this.h = 0; }
    if (needW > this.w || needH > this.h) {
      this.w = Math.max(needW, this.w); this.h = Math.max(needH, this.h); this.smaller = 0;
    } else if (needW < this.w || needH < this.h) {
      if (++this.smaller > this.patience) { this.w = needW; this.h = needH; this.smaller = 0; }
    } else this.smaller = 0;
    // the kept shape placed over the box: centred on what it needs, inside the frame, on the grid
    const place = (a, b, n) => Math.min(Math.max(Math.floor(((a + b) / 2 - n / 2) / g) * g, 0), size - n);
    let x = place(xa, xb, this.w), y = place(ya, yb, this.h);
    if (x > xa || x + this.w < xb) x = Math.min(xa, size - this.w);  // rounding left the box's edge out
    if (y > ya || y + this.h < yb) y = Math.min(ya, size - this.h);
    return { x, y, w: this.w, h: this.h };
  }
}
