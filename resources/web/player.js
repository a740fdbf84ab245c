// The player: pose in, composited image out, as morf/playback/player.py does it per frame:
// bone matrices (forward kinematics) -> skinning + neural rasterization (WebGL2, bytes into an
// RGBA32UI attachment) -> read-back (the renderer's uint8 input) -> renderer (onnxruntime-web)
// -> tail + composite over the background with the renderer's mask (WebGL) -> the canvas.
import { Skeleton } from './skeleton.js';
import { NeuralRaster } from './raster.js';
import { Compositor } from './tail.js';
import { Renderer } from './renderer.js';
import { viewProjection } from './camera.js';

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status} (is the folder complete?)`);
  return await r.arrayBuffer();
}

export async function loadAvatar(config) {
  const base = config.avatar.replace(/[^/]*$/, '');
  const doc = await (await fetch(config.avatar)).json();
  if (doc.format !== 'morf-web-avatar' || doc.version !== 1) throw new Error(`${config.avatar} is not a morf web avatar (version 1)`);
  const [texture, mesh, graph] = await Promise.all([
    fetchBytes(base + doc.texture.file), fetchBytes(base + doc.mesh.file), fetchBytes(base + doc.renderer.file)]);
  return { doc, texture: new Uint8Array(texture), mesh, graph: new Uint8Array(graph) };
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
    this.raster = new NeuralRaster(gl, avatar);
    // Software WebGL (SwiftShader, llvmpipe): the tail on the CPU, as the Python player does there.
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    this.glRenderer = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    const wanted = new URLSearchParams(location.search).get('tail');
    this.tailOnCpu = wanted ? wanted === 'js' : /swiftshader|llvmpipe|softpipe|software/i.test(this.glRenderer);
    this.compositor = new Compositor(gl, avatar.doc.renderer, this.tailOnCpu);
    this.renderer = new Renderer(runtime, avatar.graph, avatar.doc.renderer);
    this.rows = new Float32Array(this.skeleton.J * 12);
    this.timings = {};
  }

  resize(size) {
    this.raster.resize(size);
    this.compositor.resize(size);
    this.size = size;
  }

  // One frame onto the canvas. frame: the motion's row (J*3 axis-angle + 3 translation); camera:
  // pinhole of this size; canvasSize: the drawing buffer's side (0: leave the canvas alone); box:
  // the part of the image shown. timed: wait for the GL after each stage, so each gets its own
  // time ("skinning" is the bone matrices and their upload: the vertices are skinned by the
  // raster's vertex shader, so their time is in "raster"; "composite" is the tail, the composite
  // and the canvas).
  async render(frame, camera, background, { timed = false, canvasSize = 0, box = [0, 0, 1, 1] } = {}) {
    const now = () => performance.now();
    const t0 = now();
    this.skeleton.boneRows(frame, this.rows);
    this.raster.uploadBones(this.rows);
    const t1 = now();
    this.raster.draw(viewProjection(camera));
    if (timed) this.raster.sync();
    const t2 = now();
    const input = this.raster.read();
    const t3 = now();
    const outputs = await this.renderer.run(input, this.size, background);
    if (this.keepOutputs) this.lastOutputs = Object.fromEntries(Object.entries(outputs).map(([k, t]) => [k, { dims: t.dims, type: t.type, data: t.data.slice() }]));
    const t4 = now();
    if (this.compositor.cpu) this.compositor.composeCpu(input, outputs, background);
    else if (this.avatar.doc.renderer.mode === 'tail') this.compositor.composeTail(this.raster.attachment, outputs, background);
    else this.compositor.composeImage(outputs.image);
    for (const t of Object.values(outputs)) if (t.dispose) t.dispose();
    if (canvasSize) this.compositor.show(canvasSize, box);
    if (timed) this.compositor.sync(!!canvasSize);
    const t5 = now();
    this.timings = { skinning: t1 - t0, raster: t2 - t1, readback: t3 - t2, renderer: t4 - t3, composite: t5 - t4 };
    return this.timings;
  }
}
