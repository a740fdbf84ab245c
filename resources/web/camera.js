// The pinhole camera of morf/camera.py (OpenCV conventions: Xc = R X + t, image y down) and the
// orbit the page's mouse and touch gestures drive. Anny is Z-up and faces -Y; the default view is
// morf/raster/camera_paths.py's front camera (40 degree field of view, 3.4 m, aimed 5 cm below
// the pelvis, eye 15 cm higher).

export const FOV_Y_DEG = 40, DISTANCE = 3.4, TARGET_Z = -0.05, EYE_LIFT = 0.15, NEAR = 0.05, FAR = 100;

function norm(v) { const n = Math.hypot(...v); return v.map((x) => x / n); }
function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }

// A camera at eye looking at target, image up = world +Z; f from the field of view.
export function lookAt(size, eye, target, fovDeg = FOV_Y_DEG) {
  const z = norm(target.map((x, i) => x - eye[i]));
  const x = norm(cross(z, [0, 0, 1]));
  const y = cross(z, x);
  const R = [...x, ...y, ...z];
  const t = [0, 1, 2].map((i) => -(R[3 * i] * eye[0] + R[3 * i + 1] * eye[1] + R[3 * i + 2] * eye[2]));
  const f = (0.5 * size) / Math.tan((fovDeg * Math.PI) / 360);
  return { fx: f, fy: f, cx: size / 2, cy: size / 2, width: size, height: size, R, t };
}

// The column-major 4x4 of gl_projection(NEAR, FAR) @ view_matrix() (GL row 0 = image row 0).
export function viewProjection(cam) {
  const W = cam.width, H = cam.height, P = new Float64Array(16);
  P[0] = (2 * cam.fx) / W; P[2] = (2 * cam.cx) / W - 1;
  P[5] = (2 * cam.fy) / H; P[6] = (2 * cam.cy) / H - 1;
  P[10] = (FAR + NEAR) / (FAR - NEAR); P[11] = (-2 * FAR * NEAR) / (FAR - NEAR);
  P[14] = 1;
  const V = [...cam.R.slice(0, 3), cam.t[0], ...cam.R.slice(3, 6), cam.t[1], ...cam.R.slice(6, 9), cam.t[2], 0, 0, 0, 1];
  const out = new Float32Array(16);
  for (let i = 0; i < 4; i++) for (let j = 0; j < 4; j++) {
    let s = 0;
    for (let k = 0; k < 4; k++) s += P[4 * i + k] * V[4 * k + j];
    out[4 * j + i] = s;  // column-major
  }
  return out;
}

// The camera scaled to another image size (same field of view).
export function scaled(cam, size) {
  const s = size / cam.width;
  return { ...cam, fx: cam.fx * s, fy: cam.fy * s, cx: cam.cx * s, cy: cam.cy * s, width: size, height: size };
}

export class Orbit {
  constructor(element, onChange) {
    this.yaw = 0; this.pitch = 0; this.distance = DISTANCE;
    this.minDistance = 0.6; this.maxDistance = 12;
    this.onChange = onChange || (() => {});
    this.pointers = new Map();
    const el = element;
    el.style.touchAction = 'none';
    el.addEventListener('pointerdown', (e) => { el.setPointerCapture(e.pointerId); this.pointers.set(e.pointerId, [e.clientX, e.clientY]); });
    const end = (e) => { this.pointers.delete(e.pointerId); this.pinch = null; };
    el.addEventListener('pointerup', end);
    el.addEventListener('pointercancel', end);
    el.addEventListener('pointermove', (e) => this.move(e));
    el.addEventListener('wheel', (e) => { e.preventDefault(); this.zoom(Math.exp(e.deltaY * 0.001)); }, { passive: false });
    el.addEventListener('dblclick', () => { this.yaw = 0; this.pitch = 0; this.distance = DISTANCE; this.onChange(); });
  }

  move(e) {
    const last = this.pointers.get(e.pointerId);
    if (!last) return;
    this.pointers.set(e.pointerId, [e.clientX, e.clientY]);
    if (this.pointers.size === 1) {  // one finger or the mouse: orbit
      this.yaw -= (e.clientX - last[0]) * 0.01;
      this.pitch = Math.max(-1.2, Math.min(1.2, this.pitch + (e.clientY - last[1]) * 0.01));
      this.onChange();
    } else if (this.pointers.size === 2) {  // two fingers: pinch to zoom
      const [a, b] = [...this.pointers.values()];
      const span = Math.hypot(a[0] - b[0], a[1] - b[1]);
      if (this.pinch) this.zoom(this.pinch / Math.max(span, 1));
      this.pinch = span;
    }
  }

  zoom(factor) {
    this.distance = Math.max(this.minDistance, Math.min(this.maxDistance, this.distance * factor));
    this.onChange();
  }

  // The camera of a square `size` image looking at centre (the body's root, height kept).
  camera(size, centre) {
    const c = [centre[0], centre[1], centre[2] + TARGET_Z];
    const d = this.distance, cp = Math.cos(this.pitch);
    const eye = [c[0] + d * Math.sin(this.yaw) * cp, c[1] - d * Math.cos(this.yaw) * cp, c[2] + d * Math.sin(this.pitch) + EYE_LIFT];
    return lookAt(size, eye, c);
  }
}
