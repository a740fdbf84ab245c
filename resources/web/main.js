// The page: loads the folder's avatar and runtime, plays a motion with orbit and zoom, a motion
// picker, play / pause, an fps readout, and a smaller output where the device cannot hold 30 fps.
// Query parameters: size=N (fix the output side), start=N (start there, then adapt), adapt=0 (keep
// the size), crop=off|N (the renderer on the whole frame, or N pixels around the person), motion=NAME, frame=K
// and pause=1 (show one frame), threads=N, backend=wasm|webgpu, tail=js|webgl, skin=cpu|gpu, mesh=full|light|lighter|auto, canvas=2d|gl, proxy=1,
// target=FPS; bench=N, check=1, report=N run
// the checks of harness.js (tests and `morf bench web`).
import { loadRuntime } from './renderer.js';
import { Player, loadAvatar, loadMotion } from './player.js';
import { Orbit } from './camera.js';
import { runHarness, post } from './harness.js';
import { OutputSize } from './adaptive.js';
import { CanvasDisplay } from './display.js';

export const messages = [];
for (const level of ['warn', 'error']) {
  const original = console[level].bind(console);
  console[level] = (...args) => { messages.push(`${level}: ${args.join(' ')}`); original(...args); };
}
window.addEventListener('error', (e) => messages.push(`uncaught: ${e.message}`));
window.addEventListener('unhandledrejection', (e) => messages.push(`unhandled: ${e.reason && e.reason.stack ? e.reason.stack : e.reason}`));

const params = new URLSearchParams(location.search);
export const BACKGROUND = [255, 255, 255];
const TARGET_FPS = Number(params.get('target')) || 30;  // the rate the output size adapts to (target=N: tests)
const HARNESS = ['bench', 'check', 'report', 'policy'];  // the checks of harness.js
const SIZES = [640, 576, 512, 448, 384, 320, 256, 192, 128];
const $ = (id) => document.getElementById(id);

class App {
  constructor(player, runtime, config) {
    this.player = player;
    this.runtime = runtime;
    this.doc = player.avatar.doc;
    this.canvas = $('view');
    this.orbit = new Orbit(this.canvas, () => { this.dirty = true; });
    const mult = this.doc.size_multiple || 32;
    this.sizes = SIZES.map((s) => Math.floor(s / mult) * mult).filter((s, i, a) => s > 0 && a.indexOf(s) === i);
    const asked = Number(params.get('size')) || 0, start = Number(params.get('start')) || 0;
    this.fixed = asked > 0 || params.get('adapt') === '0';
    const first = asked || start;
    this.setSize(first > 0 ? Math.max(mult, Math.round(first / mult) * mult) : this.sizes[0]);
    this.output = new OutputSize(this.sizes, this.size, TARGET_FPS);
    this.motions = new Map();
    this.playing = params.get('pause') !== '1';
    this.frameIndex = Number(params.get('frame')) || 0;
    this.time = null;
    this.frames = 0;
    this.recent = [];
  }

  setSize(size) {
    this.size = size;
    this.canvas.width = this.canvas.height = size;
    this.player.resize(size);
    this.sizeFrames = 0;
    this.recent = [];
  }

  async selectMotion(name) {
    const entry = this.doc.motions.find((m) => m.name === name) || this.doc.motions[0];
    if (!entry) throw new Error('the folder holds no motion');
    if (!this.motions.has(entry.name)) this.motions.set(entry.name, await loadMotion(entry));
    this.motion = this.motions.get(entry.name);
    $('motion').value = entry.name;
    this.time = null;
    this.dirty = true;
  }

  // The camera for the body at the frame's root, and the part of the image to show: closer than
  // the scale the renderer was trained at, a wider view at that scale is drawn and its middle
  // enlarged (as morf.raster.view_scale does for the Python player).
  view(frame) {
    const J3 = this.motion.bones * 3;
    const centre = [frame[J3], frame[J3 + 1], this.motion.centre[2]];
    const cam = this.orbit.camera(this.size, centre);
    const limit = this.doc.trained_scale && this.doc.trained_scale.max_pixels_per_metre;
    const depth = cam.R[6] * centre[0] + cam.R[7] * centre[1] + cam.R[8] * centre[2] + cam.t[2];
    const ppm = cam.fx / Math.max(depth, 1e-3);
    if (!limit || ppm <= limit) return { camera: cam, box: [0, 0, 1, 1] };
    const k = limit / ppm;
    return { camera: { ...cam, fx: cam.fx * k, fy: cam.fy * k }, box: [0.5 - k / 2, 0.5 - k / 2, k, k] };
  }

  // The frame the clock has reached (playing), or the current one (paused).
  nextFrame() {
    const now = performance.now();
    if (this.playing) {
      if (this.time === null) this.time = this.frameIndex / this.motion.fps;
      else this.time += Math.min((now - this.last) / 1000, 0.25);
      this.frameIndex = Math.floor(this.time * this.motion.fps) % this.motion.frames;
    }
    this.last = now;
    const frame = this.motion.frame(this.frameIndex);
    return { frame, ...this.view(frame) };
  }

  async shown() {
    this.frames++;
    this.sizeFrames++;
    this.recent.push(performance.now());
    if (this.recent.length > 21) this.recent.shift();
    const fps = this.fps();
    if (fps) $('fps').textContent = `${fps.toFixed(1)} fps · ${this.size} px`;
    if (this.playing && this.adapt(fps, true)) this.stopPlaying = true;
    if (this.onFrame) await this.onFrame(this);
  }

  async step() {  // one frame, its stages in turn (paused: the view changed)
    const { frame, camera, box } = this.nextFrame();
    await this.player.render(frame, camera, BACKGROUND, { canvasSize: this.size, box });
    await this.shown();
  }

  fps() {
    const r = this.recent;
    return r.length < 6 ? null : (1000 * (r.length - 1)) / (r[r.length - 1] - r[0]);
  }

  // Under 30 fps a smaller output (the largest size whose pixel count the measured rate can hold);
  // with room to spare a larger one again, one step at a time (adaptive.js keeps it from see-sawing).
  adapt(fps, later = false) {  // later: the new size is set once the frames in flight are shown
    if (this.fixed) return false;
    this.output.size = this.size;
    const step = this.output.observe(fps, this.sizeFrames, performance.now());
    if (!step) return false;
    const { from, to } = step, full = this.sizes[0];
    $('notice').hidden = false;
    $('notice').textContent = step.why === 'slow'
      ? `Output ${to} × ${to} px: ${from} × ${from} ran at ${fps.toFixed(1)} fps on this device, under ${TARGET_FPS}. ` +
        `(?size=${full} in the address keeps ${full}.)`
      : `Output ${to} × ${to} px: ${from} × ${from} ran at ${fps.toFixed(1)} fps on this device, room for a larger ` +
        `output at ${TARGET_FPS} fps.` + (to < full ? ` (?size=${full} in the address keeps ${full}.)` : '');
    this.adapted = { from, fps, to, why: step.why };
    if (later) this.resizeTo = to;
    else this.setSize(to);
    return true;
  }

  async loop() {
    for (;;) {
      if (this.playing) {  // frames overlapped (player.play) until paused, a new motion or a new size
        this.stopPlaying = false;
        const motion = this.motion;
        await this.player.play(() => (this.playing && !this.stopPlaying && this.motion === motion ? this.nextFrame() : null),
                               BACKGROUND, this.size, () => this.shown());
        if (this.resizeTo) { this.setSize(this.resizeTo); this.resizeTo = null; }
        continue;
      }
      await new Promise((resolve) => requestAnimationFrame(resolve));
      if (!this.dirty) continue;
      this.dirty = false;
      await this.step();
    }
  }

  wireControls() {
    const select = $('motion'), button = $('play');
    for (const m of this.doc.motions) select.add(new Option(`${m.name} (${(m.frames / m.fps).toFixed(1)} s)`, m.name));
    select.value = this.motion.name;
    select.disabled = button.disabled = false;
    select.addEventListener('change', () => this.selectMotion(select.value));
    button.textContent = this.playing ? 'Pause' : 'Play';
    button.addEventListener('click', () => {
      this.playing = !this.playing;
      this.time = null;
      button.textContent = this.playing ? 'Pause' : 'Play';
    });
    const rt = this.runtime;
    $('status').textContent = `${rt.backend === 'webgpu' ? 'WebGPU' : 'WASM (SIMD)'}, ${rt.threads} thread${rt.threads > 1 ? 's' : ''}` +
      (rt.isolated ? '' : ' — this host does not send the cross-origin isolation headers, so the renderer runs on one ' +
       'thread (serve the folder with `morf serve`, or see docs/web.md)') + `; ${this.doc.renderer.precision} renderer`;
  }
}

async function boot() {
  const config = await (await fetch('player.json')).json();
  // The GL context on a canvas of its own: shown only where the image is made in GL (the tail's
  // passes); an image made in JavaScript goes onto the page's canvas as a 2D canvas (display.js).
  const glCanvas = document.createElement('canvas');
  glCanvas.width = glCanvas.height = 1;
  const gl = glCanvas.getContext('webgl2', { antialias: false, depth: false, alpha: false, premultipliedAlpha: false,
                                             preserveDrawingBuffer: false, powerPreference: 'high-performance' });
  if (!gl) throw new Error('this browser has no WebGL2, which the player needs');
  const [runtime, avatar] = await Promise.all([loadRuntime(config, params), loadAvatar(config)]);
  const player = new Player(gl, avatar, runtime);
  const madeInJs = player.tailOnCpu || avatar.doc.renderer.mode === 'image';
  if ((params.get('canvas') || (madeInJs ? '2d' : 'gl')) === '2d' && madeInJs) {
    player.canvas2d = new CanvasDisplay($('view'));
    player.setOption('canvas', '2d');
  } else {
    glCanvas.id = 'view';
    glCanvas.setAttribute('aria-label', $('view').getAttribute('aria-label'));
    $('view').replaceWith(glCanvas);
  }
  const app = new App(player, runtime, config);
  await app.selectMotion(params.get('motion'));
  app.wireControls();
  // The other motions too, now: once loaded, the page needs no network (the picker works offline).
  await Promise.all(avatar.doc.motions.filter((m) => !app.motions.has(m.name))
    .map(async (m) => app.motions.set(m.name, await loadMotion(m))));
  if (HARNESS.some((k) => params.has(k))) return runHarness(app, params, messages);
  return app.loop();
}

boot().catch((e) => {
  $('status').textContent = `The player could not start: ${e && e.message ? e.message : e}`;
  console.error(e && e.stack ? e.stack : String(e));
  if (HARNESS.some((k) => params.has(k))) post({ error: `${e && e.stack ? e.stack : e}`, messages });
});
