// The player: pose in, composited image out, as morf/playback/player.py does it per frame:
// bone matrices (forward kinematics) -> skinning + neural rasterization (WebGL2, bytes into an
// RGBA32UI attachment) -> read-back (the renderer's uint8 input) -> renderer (onnxruntime-web)
// -> tail + composite over the background with the renderer's mask (WebGL) -> the canvas.
// Everything from the raster on runs inside the person's window (bounds.js), not the whole frame.
import { Skeleton } from './skeleton.js';
import { NeuralRaster, loadRasterShader } from './raster.js';
import { Compositor } from './tail.js';
import { ColourFill } from './fill.js';
import { Renderer } from './renderer.js';
import { viewProjection } from './camera.js';
import { BodyBox, CropWindow } from './bounds.js';
import { ViewColours } from './view_colours.js';

// Pixels kept around the person's box (then out to the renderer's grid): the renderer's deeper
// layers see this much of the empty surroundings. 32 against 64: the window about 0.36 of a 640
// frame instead of 0.6, the renderer 2x faster, the body 38-40 dB from the whole frame's image
// instead of 40-41 (docs/web.md); past 16 pixels the whole frame's image is the background within 1 level.
export const CROP_MARGIN = 32;
// A lighter level of the mesh (morf/web/light_mesh.py) is drawn while its largest error stays under
// this many pixels: the demo avatar's 4 mm level is about 0.8 px at a full-body 640 px view, its
// page frames 35.7-38.1 dB from the Python player's over the body; zoomed closer the full mesh is drawn.
export const LOD_PIXELS = 1.5;
const REACH = 0.3;  // metres a hand or the head may come nearer the camera than the body's centre

// The mean rest vertex of the render mesh (posed by bone 0 it places the body for levelOfDetail).
function restCentre(avatar) {
  const a = avatar.doc.mesh.arrays.rest_vertices, n = a.shape[0];
  const rest = new Float32Array(avatar.mesh, a.offset, 3 * n), c = [0, 0, 0];
  for (let v = 0; v < n; v++) for (let k = 0; k < 3; k++) c[k] += rest[3 * v + k] / n;
  return c;
}

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status} (is the folder complete?)`);
  return await r.arrayBuffer();
}

export async function loadAvatar(config) {
  const base = config.avatar.replace(/[^/]*$/, '');
  const doc = await (await fetch(config.avatar)).json();
  if (doc.format !== 'morf-web-avatar' || doc.version !== 1) throw new Error(`${config.avatar} is not a morf web avatar (version 1)`);
  const head = doc.view_colours && doc.view_colours.head;
  const [texture, mesh, graph, rasterShader, views, headViews] = await Promise.all([
    fetchBytes(base + doc.texture.file), fetchBytes(base + doc.mesh.file), fetchBytes(base + doc.renderer.file),
    loadRasterShader(), doc.view_colours ? fetchBytes(base + doc.view_colours.file) : null,
    head ? fetchBytes(base + head.file) : null]);
  return { doc, texture: new Uint8Array(texture), mesh, graph: new Uint8Array(graph), rasterShader,
    views: views && new Uint8Array(views), headViews };
}

export async function loadMotion(entry) {
  const data = new Float32Array(await fetchBytes(entry.file));
  const width = entry.bones * 3 + 3;
  return { ...entry, data, width, frame: (i) => data.subarray(i * width, (i + 1) * width) };
}

export class Player {
  constructor(gl, avatar, runtime) {
    this.gl = gl;
    this.avatar = avatar;
    this.skeleton = new Skeleton(avatar.doc.skeleton);
    // Software WebGL (SwiftShader, llvmpipe): the skinning and the tail on the CPU, as the Python
    // player does there (?skin=cpu|gpu and ?tail=js|webgl override the choice).
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    this.glRenderer = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    const query = new URLSearchParams(location.search), software = /swiftshader|llvmpipe|softpipe|software/i.test(this.glRenderer);
    this.raster = new NeuralRaster(gl, avatar, query.get('skin') || (software ? 'cpu' : 'gpu'));
    // A lighter mesh where triangles cost CPU time (software WebGL): per frame the coarsest level
    // whose error stays under LOD_PIXELS at the scale the body is drawn ("auto"); a GPU draws the
    // full mesh for free.
    this.levels = (avatar.doc.mesh.levels || []).slice().sort((a, b) => b.max_error_mm - a.max_error_mm);
    this.meshChoice = query.get('mesh') || (software && this.levels.length ? 'auto' : 'full');
    this.restCentre = restCentre(avatar);
    if (this.meshChoice !== 'auto') this.raster.setMesh(this.meshChoice);
    const wanted = query.get('tail');
    this.tailOnCpu = wanted ? wanted === 'js' : software;
    this.compositor = new Compositor(gl, avatar.doc.renderer, this.tailOnCpu);
    this.renderer = new Renderer(runtime, avatar.graph, avatar.doc.renderer);
    // The colour fill's pyramid where the export took it out of the graph (morf/web/page_fill.py)
    const tail = avatar.doc.renderer.tail;
    this.fill = tail && tail.fill_levels ? new ColourFill(tail) : null;
    this.rows = new Float32Array(this.skeleton.J * 12);
    this.views = avatar.views ? new ViewColours(avatar.doc.view_colours, avatar.views, avatar.texture, this.skeleton,
      avatar.headViews) : null;
    this.bodyBox = new BodyBox(avatar.doc, avatar.mesh);
    const crop = new URLSearchParams(location.search).get('crop');  // crop=off: the whole frame; crop=N: N pixels' margin
    this.cropMargin = crop === 'off' ? -1 : crop !== null && crop !== '' ? Number(crop) : CROP_MARGIN;
    this.window = null;
    this.timings = {};
  }

  // The frame's window: the person's box and a margin, on the renderer's size multiple (or the whole frame).
  crop(camera) {
    if (!this.window || this.window.margin !== this.cropMargin) {
      this.window = new CropWindow(this.avatar.doc.size_multiple || 32, this.cropMargin);
    }
    const sk = this.raster.skin === 'cpu' ? this.raster.skinned : null;  // skinned already: projected only
    const box = this.cropMargin < 0 ? null : this.bodyBox.box(this.rows, camera, sk && sk.positions, sk && sk.used);
    return this.window.choose(box, this.size);
  }

  // A setting the harness compares A/B (compare=KEY:A,B): skin (cpu | gpu: raster.js), mesh (full |
  // light | lighter | auto: raster.js), cull (cpu | gl: raster.js), overlap (on | off: play()), path
  // (gl | js: the three at once, the GL way or the software-WebGL way), canvas (2d | gl: where an
  // image made in JavaScript is shown; both canvases are then on the page).
  setOption(key, value) {
    if (key === 'path') {  // all of them: "gl" as the page ran before (skin gpu, canvas gl, overlap off), "js" as now
      for (const [k, gl, js] of [['skin', 'gpu', 'cpu'], ['canvas', 'gl', '2d'], ['overlap', 'off', 'on']]) this.setOption(k, value === 'gl' ? gl : js);
    } else if (key === 'skin') this.raster.setSkin(value);
    else if (key === 'cull') this.raster.cull = value === 'gl' ? 'gl' : 'cpu';
    else if (key === 'mesh') {
      this.meshChoice = value;
      if (value !== 'auto') this.raster.setMesh(value);
    }
    else if (key === 'overlap') this.overlap = value === 'on';
    else if (key === 'canvas') {
      if (value === '2d' && !this.canvas2d) throw new Error('no 2D canvas on this page (?canvas=gl)');
      this.compositor.canvas2d = value === '2d' ? this.canvas2d : null;
    } else throw new Error(`no player option ${key}`);
  }

  resize(size) {
    this.raster.resize(size);
    this.compositor.resize(size);
    this.size = size;
  }

  // The coarsest level whose largest error, at the scale the body is drawn (pixels per metre at its
  // centre's depth less an arm's reach), stays under LOD_PIXELS; "full" closer up (a zoom).
  levelOfDetail(camera) {
    const r = this.rows, c = this.restCentre, R = camera.R, t = camera.t;  // rows of bone 0: the body's place
    const X = r[0] * c[0] + r[1] * c[1] + r[2] * c[2] + r[3];
    const Y = r[4] * c[0] + r[5] * c[1] + r[6] * c[2] + r[7];
    const Z = r[8] * c[0] + r[9] * c[1] + r[10] * c[2] + r[11];
    const depth = R[6] * X + R[7] * Y + R[8] * Z + t[2] - REACH;
    this.pixelsPerMetre = depth > 0.05 ? camera.fx / depth : Infinity;
    const level = this.levels.find((l) => (l.max_error_mm / 1000) * this.pixelsPerMetre <= LOD_PIXELS);
    return level ? level.name : 'full';
  }

  // A frame's GL work: bone matrices, skinning + neural rasterization, read-back. Returns the frame's
  // renderer input (valid until the frame after next is prepared: two framebuffers in turn).
  prepare(frame, camera, timed = false) {
    return this.readBack(this.draw(frame, camera, timed));
  }

  // The bone matrices, the skinning and the raster's draw calls, handed to the GL without waiting
  // for them (timed: waited for): the GL rasterizes while the page's thread does other work.
  draw(frame, camera, timed = false) {
    const t0 = performance.now();
    this.framesDrawn = (this.framesDrawn || 0) + 1;
    this.skeleton.boneRows(frame, this.rows);
    if (this.meshChoice === 'auto') this.raster.setMesh(this.levelOfDetail(camera));
    this.raster.uploadBones(this.rows);
    if (this.views) {
      const rgba = this.views.update(frame, camera.R, this.rows);
      if (rgba) this.raster.setColour(rgba);
    }
    const crop = this.crop(camera);
    this.lastCrop = crop;
    const t1 = performance.now();
    this.raster.draw(viewProjection(camera), crop);
    if (timed) this.raster.sync();
    else this.gl.flush();
    const t2 = performance.now();
    this.timings = { skinning: t1 - t0, raster: t2 - t1 };
    return { crop, t2 };
  }

  readBack({ crop, t2 }) {
    const bytes = this.raster.read();
    this.timings.readback = performance.now() - t2;
    return { bytes, attachment: this.raster.attachment, size: this.size, crop };
  }

  // The renderer on a prepared frame (in onnxruntime-web's worker when it is proxied).
  async infer(prepared, background) {
    const t0 = performance.now();
    const outputs = await this.renderer.run(prepared.bytes, prepared.crop.h, prepared.crop.w, background);
    this.timings.renderer = performance.now() - t0;
    if (this.keepOutputs) this.lastOutputs = Object.fromEntries(Object.entries(outputs).map(([k, t]) => [k, { dims: t.dims, type: t.type, data: t.data.slice() }]));
    return outputs;
  }

  // Tail + composite + canvas (canvasSize 0: the image only).
  finish(prepared, outputs, background, { timed = false, canvasSize = 0, box = [0, 0, 1, 1] } = {}) {
    const t0 = performance.now();
    const crop = prepared.crop;
    if (this.fill && !(this.fill.spec.fill in outputs)) {  // in JavaScript while the GL draws the next frame (play's overlap)
      const fill = outputs[this.fill.spec.fill] = this.fill.run(prepared.bytes, crop.w, crop.h);
      this.timings.fill = performance.now() - t0;
      if (this.keepOutputs) this.lastOutputs[this.fill.spec.fill] = { ...fill, data: fill.data.slice() };
    }
    if (this.compositor.cpu) this.compositor.composeCpu(prepared.bytes, outputs, background, crop);
    else if (this.avatar.doc.renderer.mode === 'tail') this.compositor.composeTail(prepared.attachment, outputs, background, crop);
    else this.compositor.composeImage(outputs.image, background, crop);
    for (const t of Object.values(outputs)) if (t.dispose) t.dispose();
    if (timed) this.compositor.sync(false);
    const t1 = performance.now();
    if (canvasSize) this.compositor.show(canvasSize, box);
    if (timed) this.compositor.sync(!!canvasSize);
    const t2 = performance.now();
    // composite: the colour fill, the tail, the composite and the canvas; of it, "fill" is the
    // colour fill's pyramid and "show" the canvas alone
    this.timings.composite = t2 - t0;
    this.timings.show = t2 - t1;
  }

  // One frame onto the canvas, its stages one after the other. frame: the motion's row (J*3
  // axis-angle + 3 translation); camera: pinhole of this size; canvasSize: the drawing buffer's side
  // (0: leave the canvas alone); box: the part of the image shown. timed: wait for the GL after each
  // stage, so each gets its own time ("skinning" is the bone matrices and their upload: the vertices
  // are skinned by the raster's vertex shader, so their time is in "raster"; "composite" is the
  // tail, the composite and the canvas).
  async render(frame, camera, background, options = {}) {
    const prepared = this.prepare(frame, camera, options.timed);
    const outputs = await this.infer(prepared, background);
    this.finish(prepared, outputs, background, options);
    return this.timings;
  }

  // Frames one after another, frame t+1's raster (in the GL's own threads) overlapping frame t's
  // tail and composite (JavaScript), and frame t's renderer overlapping frame t+1's GL work where
  // onnxruntime-web runs in its worker (proxy=1). next() -> {frame, camera, box}, or null to stop;
  // shown() is awaited once a frame is on the canvas. overlap = false: frame t+1's GL work only
  // after frame t is shown (for comparison).
  async play(next, background, canvasSize, shown = async () => {}) {
    let pending = null;
    for (;;) {
      const want = next();
      let drawn = want && this.overlap !== false ? this.draw(want.frame, want.camera) : null;
      if (pending) {
        this.finish(pending.prepared, await pending.outputs, background, { canvasSize, box: pending.box });
        await shown();
      }
      if (!want) return;
      if (!drawn) drawn = this.draw(want.frame, want.camera);
      const prepared = this.readBack(drawn);
      pending = { prepared, box: want.box, outputs: this.infer(prepared, background) };
    }
  }
}
