// The texture's colour channels (0-2) by view, as the Python player draws them
// (morf/avatar/view_colour.py, morf/playback/player.py): the body's orientation relative to the
// camera picks the three nearest anchor orientations, blended with integer weights summing to 256
// (each the square of how much nearer it is than the fourth) that fall to zero as an anchor leaves
// the three; the blend is written into the raster's first
// texture (channels 0-3, channel 3 kept) only when the weights change.
import { mul3, rodrigues } from './skeleton.js';

const BLEND = 3;

export class ViewColours {
  // doc: avatar.json's "view_colours" ({count, anchors: K*9 row-major}); bytes: K x Ht x Wt x 3;
  // texture: the Ht x Wt x 16 texture bytes (channel 3 is kept); skeleton: its U (reference rotations).
  constructor(doc, bytes, texture, skeleton) {
    this.count = doc.count;
    this.anchors = [];
    for (let k = 0; k < this.count; k++) this.anchors.push(Float64Array.from(doc.anchors.slice(9 * k, 9 * k + 9)));
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

  // [indices, integer weights summing to 256] of the blend for an orientation (3 x 3, row-major).
  weights(O) {
    const ang = this.anchors.map((A) => {
      let tr = 0;
      for (let i = 0; i < 9; i++) tr += A[i] * O[i];  // trace(A^T O)
      return Math.acos(Math.min(1, Math.max(-1, (tr - 1) / 2)));
    });
    const order = ang.map((a, i) => [a, i]).sort((x, y) => x[0] - y[0] || x[1] - y[1]).map((x) => x[1]);
    let idx, w;
    if (this.count <= BLEND) {
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
  update(frame, cameraR) {
    const [idx, q] = this.weights(this.orientation(frame, cameraR));
    const key = idx.join(',') + ';' + q.join(',');
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
    return out;
  }
}
