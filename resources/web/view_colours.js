// The texture's colour channels (0-2) by view, as the Python player draws them
// (morf/avatar/view_colour.py, morf/playback/player.py): the body's orientation relative to the
// camera picks the three nearest anchor orientations, blended with integer weights summing to 256
// (each the square of how much nearer it is than the fourth) that fall to zero as an anchor leaves
// the three; the blend is written into the raster's first
// texture (channels 0-3, channel 3 kept) only when the weights change. An avatar with the head's own
// colours (morf/avatar/head_colour.py) blends those by the head bone's orientation the same way and
// lays them over its texels by each texel's head share, in integers as the Python player does.
import { mul3, rodrigues } from './skeleton.js';

const BLEND = 3;

function anchorsOf(doc) {
  const out = [];
  for (let k = 0; k < doc.count; k++) out.push(Float64Array.from(doc.anchors.slice(9 * k, 9 * k + 9)));
  return out;
}

export class ViewColours {
  // doc: avatar.json's "view_colours" ({count, anchors: K*9 row-major, head?}); bytes: K x Ht x Wt x 3;
  // texture: the Ht x Wt x 16 texture bytes (channel 3 is kept); skeleton: its U (reference rotations);
  // headBytes: head_colours.bin (n int32 texel indices, n shares, Kh x n x 3 colours) when doc.head.
  constructor(doc, bytes, texture, skeleton, headBytes = null) {
    this.count = doc.count;
    this.anchors = anchorsOf(doc);
    this.head = null;
    if (doc.head && headBytes) {
      const n = doc.head.texels;
      this.head = { bone: doc.head.bone, n, anchors: anchorsOf(doc.head), texels: new Int32Array(headBytes, 0, n),
        share: new Uint8Array(headBytes, 4 * n, n), colours: new Uint8Array(headBytes, 5 * n) };
    }
    this.bytes = bytes;
    this.texels = bytes.length / (3 * this.count);
    this.U = skeleton.U[0];
    this.Ut = skeleton.Ut[0];
    this.rgba = new Uint8Array(this.texels * 4);
    for (let t = 0; t < this.texels; t++) this.rgba[4 * t + 3] = texture[16 * t + 3];
    this.key = null;
  }

  // The orientation relative to the camera: R_cam U0^T D0 U0 (D0 the root's axis-angle).
  orientation(frame, cameraR) {
    const W = mul3(this.Ut, mul3(rodrigues(frame[0], frame[1], frame[2]), this.U));
    return mul3(Float64Array.from(cameraR), W);
  }

  // The head's orientation relative to the camera: R_cam times the head bone's skinning rotation,
  // the top-left 3 x 3 of its rows (boneRows' output, 12 floats a bone).
  headOrientation(rows, cameraR) {
    const o = 12 * this.head.bone, T = new Float64Array(9);
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) T[3 * i + j] = rows[o + 4 * i + j];
    return mul3(Float64Array.from(cameraR), T);
  }

  // [indices, integer weights summing to 256] of the blend for an orientation (3 x 3, row-major).
  weights(O, anchors = this.anchors) {
    const ang = anchors.map((A) => {
      let tr = 0;
      for (let i = 0; i < 9; i++) tr += A[i] * O[i];  // trace(A^T O)
      return Math.acos(Math.min(1, Math.max(-1, (tr - 1) / 2)));
    });
    const order = ang.map((a, i) => [a, i]).sort((x, y) => x[0] - y[0] || x[1] - y[1]).map((x) => x[1]);
    let idx, w;
    if (anchors.length <= BLEND) {
      idx = order;
      w = order.map(() => 1 / order.length);
    } else {
      idx = order.slice(0, BLEND);
      w = idx.map((i) => (ang[order[BLEND]] - ang[i]) ** 2);  // squared, as morf/avatar/view_colour.py
      const total = w.reduce((s, v) => s + v, 0);
      w = total <= 1e-12 ? w.map(() => 1 / BLEND) : w.map((v) => v / total);
    }
    const q = w.map((v) => Math.floor(v * 256));
    let best = 0;
    for (let i = 1; i < w.length; i++) if (w[i] > w[best]) best = i;
    q[best] += 256 - q.reduce((s, v) => s + v, 0);
    const keep = q.map((v, i) => i).filter((i) => q[i] > 0);
    return [keep.map((i) => idx[i]), keep.map((i) => q[i])];
  }

  // The RGBA bytes of the raster's first texture for this frame, or null when the blend is unchanged.
  // rows: the frame's bone rows (the head's orientation; unused without head colours).
  update(frame, cameraR, rows) {
    const [idx, q] = this.weights(this.orientation(frame, cameraR));
    const hw = this.head ? this.weights(this.headOrientation(rows, cameraR), this.head.anchors) : null;
    const key = idx.join(',') + ';' + q.join(',') + (hw ? '|' + hw[0].join(',') + ';' + hw[1].join(',') : '');
    if (key === this.key) return null;
    this.key = key;
    const n = this.texels, out = this.rgba, b = this.bytes;
    for (let t = 0; t < n; t++) {
      for (let c = 0; c < 3; c++) {
        let s = 128;
        for (let k = 0; k < idx.length; k++) s += b[(idx[k] * n + t) * 3 + c] * q[k];
        out[4 * t + c] = s >> 8;
      }
    }
    if (hw) this.layOverHead(hw[0], hw[1]);
    return out;
  }

  // The head's blend laid over its texels: head = (128 + sum q_k c_k) >> 8, then
  // (share * head + (255 - share) * body + 127) / 255, rounded down, as morf/avatar/head_colour.py.
  layOverHead(idx, q) {
    const h = this.head, n = h.n, out = this.rgba;
    for (let i = 0; i < n; i++) {
      const t = h.texels[i], s = h.share[i];
      for (let c = 0; c < 3; c++) {
        let v = 128;
        for (let k = 0; k < idx.length; k++) v += h.colours[(idx[k] * n + i) * 3 + c] * q[k];
        v >>= 8;
        out[4 * t + c] = Math.floor((s * v + (255 - s) * out[4 * t + c] + 127) / 255);
      }
    }
  }
}
