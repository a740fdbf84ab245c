// The colour fill's push-pull pyramid (morf/web/page_fill.py's fill_pyramid, the renderer graph's
// FILL output): 2x2 means of the texture colour and the coverage `levels` times, then bilinear
// pulls back to half resolution. The web export takes it out of the graph (its ~80 small nodes
// were a quarter of onnxruntime-web's kernel time); here it is one pass over the read-back bytes
// and a few small ones. The window's sides are multiples of 2**levels, so every halving is exact.

import { taps } from './cpu_tail.js';

const COVERAGE_FLOOR = 1e-4;  // push_pull_fill's floor on a level's coverage

export class ColourFill {
  constructor(spec) {
    this.spec = spec;
    this.levels = spec.fill_levels;
    this.W = this.H = 0;
    this.tapsOf = new Map();  // side -> its 2x taps
    this.lineBuffer = new Float32Array(0);
  }

  resize(W, H) {
    if (W === this.W && H === this.H) return;
    if (W % (1 << this.levels) || H % (1 << this.levels)) throw new Error(`a ${W} x ${H} window does not halve ${this.levels} times`);
    this.W = W; this.H = H;
    // per level k = 1..levels: colour (3 planes) and coverage, and the pull's accumulator (4 planes)
    this.col = []; this.cov = []; this.acc = [];
    for (let k = 1, w = W / 2, h = H / 2; k <= this.levels; k++, w /= 2, h /= 2) {
      this.col.push(new Float32Array(3 * w * h));
      this.cov.push(new Float32Array(w * h));
      this.acc.push(new Float32Array(4 * w * h));
    }
    this.tensor = { dims: [1, 4, H / 2, W / 2], type: 'float32', data: this.acc[0] };
  }

  // raster: Uint8Array (H*W*16). Returns the (1, 4, H/2, W/2) float32 tensor (reused by the next call).
  run(raster, W, H) {
    this.resize(W, H);
    this.first(raster);
    for (let k = 1; k < this.levels; k++) this.halve(k);
    const L = this.levels - 1;
    const top = this.acc[L], n = this.cov[L].length;
    top.set(this.col[L]);
    top.set(this.cov[L], 3 * n);
    for (let k = L - 1; k >= 0; k--) this.pull(k);
    return this.tensor;
  }

  // Level 1 from the bytes: the 2x2 mean of the scaled colour and of the coverage. Off the body all
  // 16 bytes are the zero point (colour 0), so a block without coverage is zero.
  first(raster) {
    const s = this.spec, zp = s.zero_point, cc = s.coverage_channel, W = this.W, w = W / 2, h = this.H / 2, n = w * h;
    const c0 = 0.25 * s.colour_scale[0], c1 = 0.25 * s.colour_scale[1], c2 = 0.25 * s.colour_scale[2];
    const col = this.col[0], cov = this.cov[0], row = 16 * W;
    for (let y = 0; y < h; y++) {
      for (let x = 0; x < w; x++) {
        const i = y * w + x, p = 2 * y * row + 32 * x, q = p + row;
        const k = (raster[p + cc] !== zp) + (raster[p + 16 + cc] !== zp) + (raster[q + cc] !== zp) + (raster[q + 16 + cc] !== zp);
        cov[i] = 0.25 * k;
        if (k === 0) { col[i] = 0; col[n + i] = 0; col[2 * n + i] = 0; continue; }
        col[i] = c0 * (raster[p] + raster[p + 16] + raster[q] + raster[q + 16] - 4 * zp);
        col[n + i] = c1 * (raster[p + 1] + raster[p + 17] + raster[q + 1] + raster[q + 17] - 4 * zp);
        col[2 * n + i] = c2 * (raster[p + 2] + raster[p + 18] + raster[q + 2] + raster[q + 18] - 4 * zp);
      }
    }
  }

  // Level k + 1 from level k (0-based arrays): 2x2 means of the colour and the coverage planes.
  halve(k) {
    const w = this.W >> (k + 1), h = this.H >> (k + 1), W2 = 2 * w, n = w * h, N = 4 * n;
    const planes = [[this.col[k - 1], this.col[k], 3], [this.cov[k - 1], this.cov[k], 1]];
    for (const [src, dst, C] of planes) {
      for (let c = 0; c < C; c++) {
        const so = c * N, d = c * n;
        for (let y = 0; y < h; y++) {
          for (let x = 0; x < w; x++) {
            const p = so + 2 * y * W2 + 2 * x;
            dst[d + y * w + x] = 0.25 * (src[p] + src[p + 1] + src[p + W2] + src[p + W2 + 1]);
          }
        }
      }
    }
  }

  // The pull onto level k (0-based) from level k + 1's accumulator: a = min(4 coverage, 1);
  // acc = a * (colour / max(coverage, floor), 1) + (1 - a) * 2x bilinear of the coarser acc (its
  // rows interpolated once per output row; where a is 1 the coarser level does not count).
  pull(k) {
    const w = this.W >> (k + 1), h = this.H >> (k + 1), n = w * h, cw = w / 2, cn = cw * (h / 2);
    const up = this.acc[k + 1], out = this.acc[k], col = this.col[k], cov = this.cov[k];
    const tx = this.taps(cw), ty = this.taps(h / 2), line = this.line(4 * cw);
    const n2 = 2 * n, n3 = 3 * n, cw2 = 2 * cw, cw3 = 3 * cw;
    for (let y = 0; y < h; y++) {
      const r0 = ty.a[y] * cw, r1 = ty.b[y] * cw, fy = ty.f[y], gy = 1 - fy;
      let rowCovered = true;
      for (let x = 0, i = y * w; x < w; x++, i++) if (cov[i] < 0.25) { rowCovered = false; break; }
      if (!rowCovered) {
        for (let c = 0; c < 4; c++) {
          const o = c * cn, l = c * cw;
          for (let x = 0; x < cw; x++) line[l + x] = gy * up[o + r0 + x] + fy * up[o + r1 + x];
        }
      }
      for (let x = 0, i = y * w; x < w; x++, i++) {
        const c = cov[i];
        if (c >= 0.25) {  // a = 1
          out[i] = col[i] / c; out[n + i] = col[n + i] / c; out[n2 + i] = col[n2 + i] / c; out[n3 + i] = 1;
          continue;
        }
        const a = 4 * c, b = 1 - a, m = Math.max(c, COVERAGE_FLOOR);
        const xa = tx.a[x], xb = tx.b[x], fx = tx.f[x], gx = 1 - fx;
        out[i] = a * (col[i] / m) + b * (gx * line[xa] + fx * line[xb]);
        out[n + i] = a * (col[n + i] / m) + b * (gx * line[cw + xa] + fx * line[cw + xb]);
        out[n2 + i] = a * (col[n2 + i] / m) + b * (gx * line[cw2 + xa] + fx * line[cw2 + xb]);
        out[n3 + i] = a + b * (gx * line[cw3 + xa] + fx * line[cw3 + xb]);
      }
    }
  }

  taps(n) {  // the 2x taps of a side, kept per side
    let t = this.tapsOf.get(n);
    if (!t) { t = taps(n); this.tapsOf.set(n, t); }
    return t;
  }

  line(n) {  // a row buffer of at least n values
    if (this.lineBuffer.length < n) this.lineBuffer = new Float32Array(n);
    return this.lineBuffer;
  }
}
