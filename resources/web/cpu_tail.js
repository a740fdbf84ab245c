// The renderer's tail and composite on the CPU (plain JavaScript), for software WebGL: the same
// function as tail.js's passes (morf/export/compiled_tail.py, reference_tail), on the read-back
// raster and the graph's half-resolution outputs, which are both in memory already. In
// SwiftShader a full-resolution pass with texel loops costs more than this loop (the Python
// player's reason for its compiled tail on the CPU, too).

function taps(n) {  // 2x bilinear, half-pixel centres, clamped: per output index (a, b, weight of b)
  const a = new Int32Array(2 * n), b = new Int32Array(2 * n), f = new Float32Array(2 * n);
  for (let x = 0; x < 2 * n; x++) {
    const s = Math.min(Math.max((x + 0.5) / 2 - 0.5, 0), n - 1), i = Math.floor(s);
    a[x] = i; b[x] = Math.min(i + 1, n - 1); f[x] = s - i;
  }
  return { a, b, f };
}

// Where each pixel's window of +-m along rows (step 1) or columns (step = width) lies inside the
// coverage, the window clipped to the image: runs of covered pixels counted from both ends.
function erode(src, dst, width, height, m, alongRows) {
  const lines = alongRows ? height : width, len = alongRows ? width : height, step = alongRows ? 1 : width;
  const run = new Int32Array(len);
  for (let l = 0; l < lines; l++) {
    const base = alongRows ? l * width : l;
    let c = m + 1;  // outside the image counts as covered (the window is clipped)
    for (let i = 0; i < len; i++) { c = src[base + i * step] ? c + 1 : 0; run[i] = c; }
    c = m + 1;
    for (let i = len - 1; i >= 0; i--) {
      c = src[base + i * step] ? c + 1 : 0;
      dst[base + i * step] = run[i] > m && c > m ? 1 : 0;
    }
  }
}

export class CpuTail {
  constructor(spec) {
    this.spec = spec;
    this.W = this.H = 0;
  }

  resize(W, H) {  // the window's width and height (even)
    if (W === this.W && H === this.H) return;
    this.W = W; this.H = H;
    const n = W * H;
    this.rgba = new Uint8ClampedArray(4 * n);  // stores round-half-even and clip, as np.rint + clip
    this.covered = new Uint8Array(n);
    this.rows = new Uint8Array(n);
    this.inside = new Uint8Array(n);
    this.tx = taps(W / 2);
    this.ty = taps(H / 2);
    this.lines = Array.from({ length: 8 }, () => new Float32Array(W / 2));
  }

  // raster: Uint8Array (H*W*16); head, fill: Float32Array planar (4, H/2, W/2); background: [r, g, b].
  // Returns the (H, W) RGBA image (a view of a buffer reused by the next call).
  run(raster, head, fill, background) {
    const s = this.spec, W = this.W, H = this.H, w = W / 2, plane = w * (H / 2), zp = s.zero_point, m = s.opaque_margin;
    const { a, b, f } = this.tx, ty = this.ty, covered = this.covered, inside = this.inside, out = this.rgba;
    for (let i = 0, n = W * H; i < n; i++) covered[i] = raster[16 * i] !== zp ? 1 : 0;
    if (m > 0) { erode(covered, this.rows, W, H, m, true); erode(this.rows, inside, W, H, m, false); }
    const [c0, c1, c2] = s.colour_scale, ls = s.logit_scale, lo = s.logit_offset, wmin = s.weight_min;
    const bg0 = background[0] / 255, bg1 = background[1] / 255, bg2 = background[2] / 255;
    const rows = this.lines;
    const [H0, H1, H2, H3, F0, F1, F2, F3] = rows;
    for (let y = 0; y < H; y++) {
      // The output row's vertical interpolation of the 8 half-resolution planes, once per row.
      const r0 = ty.a[y] * w, r1 = ty.b[y] * w, fy = ty.f[y], gy = 1 - fy;
      for (let k = 0; k < 4; k++) {
        const Hk = rows[k], Fk = rows[4 + k], o = k * plane;
        for (let x = 0; x < w; x++) {
          Hk[x] = gy * head[o + r0 + x] + fy * head[o + r1 + x];
          Fk[x] = gy * fill[o + r0 + x] + fy * fill[o + r1 + x];
        }
      }
      for (let x = 0; x < W; x++) {
        const i = y * W + x, xa = a[x], xb = b[x], fx = f[x], gx = 1 - fx;
        let mask = 1 / (1 + Math.exp(-((gx * H3[xa] + fx * H3[xb]) * ls + lo)));
        if (m > 0 && inside[i]) mask = 1;
        let R = bg0, G = bg1, B = bg2;
        if (mask > 1 / 2048) {  // below it the body cannot move the byte off the background's
          const p = 16 * i;
          let cr = (raster[p] - zp) * c0, cg = (raster[p + 1] - zp) * c1, cb = (raster[p + 2] - zp) * c2;
          if (!covered[i]) {
            const wt = Math.max(gx * F3[xa] + fx * F3[xb], wmin);
            cr += (gx * F0[xa] + fx * F0[xb]) / wt;
            cg += (gx * F1[xa] + fx * F1[xb]) / wt;
            cb += (gx * F2[xa] + fx * F2[xb]) / wt;
          }
          const inv = 1 - mask;
          R = (gx * H0[xa] + fx * H0[xb] + cr) * mask + inv * bg0;
          G = (gx * H1[xa] + fx * H1[xb] + cg) * mask + inv * bg1;
          B = (gx * H2[xa] + fx * H2[xb] + cb) * mask + inv * bg2;
        }
        const q = 4 * i;
        out[q] = R * 255; out[q + 1] = G * 255; out[q + 2] = B * 255; out[q + 3] = 255;
      }
    }
    return new Uint8Array(out.buffer);
  }
}
