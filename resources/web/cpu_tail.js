// The renderer's tail and composite on the CPU (plain JavaScript), for software WebGL: the same
// function as tail.js's passes (morf/export/compiled_tail.py, reference_tail), on the read-back
// raster and the graph's half-resolution outputs, which are both in memory already. In
// SwiftShader a full-resolution pass with texel loops costs more than this loop (the Python
// player's reason for its compiled tail on the CPU, too).

export function taps(n) {  // 2x bilinear, half-pixel centres, clamped: per output index (a, b, weight of b)
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

// -ln(2047): below this logit the mask is under 1/2048, where the body cannot move a byte off the
// background's (the pixel is the background's word without an exp()).
const LOGIT_FLOOR = -Math.log(2047);

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
    this.words = new Uint32Array(this.rgba.buffer);  // the background's pixels as one store
    this.image = typeof ImageData === 'undefined' ? null : new ImageData(this.rgba, W, H);  // for a 2D canvas
    this.covered = new Uint8Array(n);
    this.rows = new Uint8Array(n);
    this.inside = new Uint8Array(n);
    this.tx = taps(W / 2);
    this.ty = taps(H / 2);
    this.lines = Array.from({ length: 8 }, () => new Float32Array(W / 2));
  }

  // raster: Uint8Array (H*W*16); head, fill: Float32Array planar (4, H/2, W/2); background: [r, g, b].
  // Returns the (H, W) RGBA image (this.rgba: a buffer reused by the next call).
  run(raster, head, fill, background) {
    const s = this.spec, W = this.W, H = this.H, zp = s.zero_point, m = s.opaque_margin;
    const covered = this.covered, inside = this.inside;
    for (let i = 0, n = W * H; i < n; i++) covered[i] = raster[16 * i] !== zp ? 1 : 0;
    if (m > 0) { erode(covered, this.rows, W, H, m, true); erode(this.rows, inside, W, H, m, false); }
    // little-endian RGBA word of the background (the stores below are Uint8Clamped: round, clip)
    const word = (background[0] | (background[1] << 8) | (background[2] << 16) | (255 << 24)) >>> 0;
    for (let y = 0; y < H; y++) this.row(y, raster, head, fill, background, word);
    return this.rgba;
  }

  // One output row: the mask's line first; the other seven planes' lines and the colour only where
  // some pixel of the row shows the body (most of the window is background).
  row(y, raster, head, fill, background, word) {
    const s = this.spec, W = this.W, w = W / 2, plane = w * (this.H / 2), zp = s.zero_point, m = s.opaque_margin;
    const { a, b, f } = this.tx, ty = this.ty, covered = this.covered, inside = this.inside, out = this.rgba, words = this.words;
    const r0 = ty.a[y] * w, r1 = ty.b[y] * w, fy = ty.f[y], gy = 1 - fy, lines = this.lines;
    const [H0, H1, H2, H3, F0, F1, F2, F3] = lines;
    const ls = s.logit_scale, lo = s.logit_offset, o3 = 3 * plane;
    let hi = -Infinity;
    for (let x = 0; x < w; x++) {
      const v = gy * head[o3 + r0 + x] + fy * head[o3 + r1 + x];
      H3[x] = v;
      if (v > hi) hi = v;
    }
    const base = y * W;
    let any = hi * ls + lo > LOGIT_FLOOR || ls < 0;
    if (!any && m > 0) for (let x = 0; x < W && !any; x++) any = inside[base + x] === 1;
    if (!any) { words.fill(word, base, base + W); return; }
    for (let k = 0; k < 3; k++) {  // the vertical interpolation of the other planes, once per row
      const Hk = lines[k], o = k * plane;
      for (let x = 0; x < w; x++) Hk[x] = gy * head[o + r0 + x] + fy * head[o + r1 + x];
    }
    for (let k = 0; k < 4; k++) {
      const Fk = lines[4 + k], o = k * plane;
      for (let x = 0; x < w; x++) Fk[x] = gy * fill[o + r0 + x] + fy * fill[o + r1 + x];
    }
    const [c0, c1, c2] = s.colour_scale, wmin = s.weight_min;
    const bg0 = background[0] / 255, bg1 = background[1] / 255, bg2 = background[2] / 255;
    for (let x = 0; x < W; x++) {
      const i = base + x, xa = a[x], xb = b[x], fx = f[x], gx = 1 - fx;
      const z = (gx * H3[xa] + fx * H3[xb]) * ls + lo;
      const held = m > 0 && inside[i] === 1;
      if (!held && !(z > LOGIT_FLOOR)) { words[i] = word; continue; }
      const mask = held ? 1 : 1 / (1 + Math.exp(-z));
      const p = 16 * i;
      let cr = (raster[p] - zp) * c0, cg = (raster[p + 1] - zp) * c1, cb = (raster[p + 2] - zp) * c2;
      if (covered[i] === 0) {
        const wt = Math.max(gx * F3[xa] + fx * F3[xb], wmin);
        cr += (gx * F0[xa] + fx * F0[xb]) / wt;
        cg += (gx * F1[xa] + fx * F1[xb]) / wt;
        cb += (gx * F2[xa] + fx * F2[xb]) / wt;
      }
      const inv = 1 - mask, q = 4 * i;
      out[q] = ((gx * H0[xa] + fx * H0[xb] + cr) * mask + inv * bg0) * 255;
      out[q + 1] = ((gx * H1[xa] + fx * H1[xb] + cg) * mask + inv * bg1) * 255;
      out[q + 2] = ((gx * H2[xa] + fx * H2[xb] + cb) * mask + inv * bg2) * 255;
      out[q + 3] = 255;
    }
  }
}
