// Bone skinning matrices from a pose, in the page: the forward kinematics of
// morf/export/skeleton.py (SkinningSkeleton.bone_transforms, Anny's "local-ref"), in float64.
// For bone c with parent p, rest pose P_c = [R_c | h_c], reference orientation U_c, delta D_c:
//   K_c = [U_p^T D_c U_c | U_p^T (q_c - q_p)],  W_0 = [U_0^T D_0 U_0 | U_0^T d_0],  W_c = W_p K_c,
//   T_c = W_c P_c^-1.

export function mul3(a, b) {  // 3x3 row-major products
  const o = new Float64Array(9);
  for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) {
    o[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
  }
  return o;
}
function transpose3(a) {
  return Float64Array.of(a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]);
}
function apply3(a, v) {
  return [a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
          a[6] * v[0] + a[7] * v[1] + a[8] * v[2]];
}

// Axis-angle -> rotation matrix, the closed form of rotvec_to_matrix_rodrigues (safe at zero).
export function rodrigues(x, y, z) {
  const t2 = x * x + y * y + z * z, t = Math.sqrt(t2), small = t2 < 1e-12;
  const a = small ? 1 - t2 / 6 : Math.sin(t) / t;
  const b = small ? 0.5 - t2 / 24 : (1 - Math.cos(t)) / t2;
  const K = Float64Array.of(0, -z, y, z, 0, -x, -y, x, 0), KK = mul3(K, K);
  const o = new Float64Array(9);
  for (let i = 0; i < 9; i++) o[i] = (i % 4 === 0 ? 1 : 0) + a * K[i] + b * KK[i];
  return o;
}

export class Skeleton {
  // doc: avatar.json's "skeleton" (parents, rest_rotations, rest_heads, reference_rotations, flat row-major)
  constructor(doc) {
    const J = doc.parents.length;
    this.J = J;
    this.parents = doc.parents;
    const m = (flat, j) => Float64Array.from(flat.slice(9 * j, 9 * j + 9));
    this.R = []; this.U = []; this.h = [];
    for (let j = 0; j < J; j++) {
      this.R.push(m(doc.rest_rotations, j));
      this.U.push(m(doc.reference_rotations, j));
      this.h.push(doc.rest_heads.slice(3 * j, 3 * j + 3));
    }
    this.Rt = this.R.map(transpose3);
    this.Ut = this.U.map(transpose3);
    // The pose-free part: K's translation U_p^T A_p (h_c - h_p), A_p = U_p R_p^T (A_0 = I).
    this.kTransl = [];
    for (let j = 0; j < J; j++) {
      const p = Math.max(this.parents[j], 0);
      const A = p === 0 ? Float64Array.of(1, 0, 0, 0, 1, 0, 0, 0, 1) : mul3(this.U[p], this.Rt[p]);
      const d = [0, 1, 2].map((k) => this.h[j][k] - this.h[p][k]);
      this.kTransl.push(apply3(this.Ut[p], apply3(A, d)));
    }
  }

  // frame: Float32Array of J*3 axis-angle values then 3 translation values.
  // out: Float32Array(J * 12), per bone the top three rows of T_c (4 floats each).
  boneRows(frame, out) {
    const J = this.J, Wr = new Array(J), Wt = new Array(J);
    for (let c = 0; c < J; c++) {
      const D = rodrigues(frame[3 * c], frame[3 * c + 1], frame[3 * c + 2]);
      const M = mul3(D, this.U[c]);
      const p = this.parents[c];
      if (p < 0) {
        Wr[c] = mul3(this.Ut[0], M);
        Wt[c] = apply3(this.Ut[0], [frame[3 * J], frame[3 * J + 1], frame[3 * J + 2]]);
      } else {
        Wr[c] = mul3(Wr[p], mul3(this.Ut[p], M));
        const k = apply3(Wr[p], this.kTransl[c]);
        Wt[c] = [k[0] + Wt[p][0], k[1] + Wt[p][1], k[2] + Wt[p][2]];
      }
      const Tr = mul3(Wr[c], this.Rt[c]), th = apply3(Tr, this.h[c]);
      for (let i = 0; i < 3; i++) {
        out[12 * c + 4 * i] = Tr[3 * i];
        out[12 * c + 4 * i + 1] = Tr[3 * i + 1];
        out[12 * c + 4 * i + 2] = Tr[3 * i + 2];
        out[12 * c + 4 * i + 3] = Wt[c][i] - th[i];
      }
    }
    return out;
  }
}
