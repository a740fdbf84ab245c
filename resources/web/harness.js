// Checks the page runs for the tests and `morf bench web` (served by morf/web/server.py, which
// takes what the page posts to ./result):
//   ?bench=N[&size=S]  at S x S (default 640): N frames with each stage waited for -> per-stage
//                      times (fine=1: the tail's passes too); N frames one after another; N frames
//                      as the page plays them (renderer overlapped with the next frame's GL) ->
//                      fps; then the adaptive size the page settles on (noadapt=1: not measured)
//                      and the fps there; threads, backend, WebGL renderer
//   ?check=1           renders the frames of ./check.json ({frames: [{pose, camera, size}],
//                      background}) and posts the images (RGBA, rows top first, base64)
//   ?report=N          plays as a user sees it for N frames, then posts what was shown
//   ?bench=N&compare=crop  N frames, each stage waited for, the person's window and the whole frame
//                      in turn frame by frame (the same load falls on both): per-stage times of each
//   ?bench=N&compare=KEY:A,B  two settings of a player option (or graph:A,B, two forms of the renderer
//                      graph) in turn, in blocks of `block` frames (played=1: as the page plays them)
//   ?policy=[[fps, frames, ms], ...]  the adaptive size's decisions (adaptive.js) for those
//                      measurements, starting at the largest size with the page's target
import { OutputSize } from './adaptive.js';

const STAGES = ['skinning', 'raster', 'readback', 'renderer', 'composite'];
const PARTS = ['show', 'fill'];  // parts of a stage: the canvas pass and the colour fill of "composite"

// A mark the server stamps with the time and the browser's CPU seconds (morf/web/server.py).
async function mark(name) {
  await fetch(`./mark?name=${name}`, { method: 'POST' });
}

export async function post(body) {
  await fetch('./result', { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
}

function base64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

function environment(app) {
  const gl = app.player.gl, info = gl.getExtension('WEBGL_debug_renderer_info');
  return {
    user_agent: navigator.userAgent, cores: navigator.hardwareConcurrency,
    webgl: info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER),
    backend: app.runtime.backend, threads: app.runtime.threads, isolated: app.runtime.isolated, proxy: app.runtime.proxy,
    renderer: { mode: app.doc.renderer.mode, precision: app.doc.renderer.precision },
    tail: app.doc.renderer.mode === 'tail' ? (app.player.tailOnCpu ? 'js' : 'webgl') : null,
    skin: app.player.raster.skin, ...meshNow(app), display: app.player.compositor.canvas2d ? '2d' : 'gl',
    frames_drawn: app.player.framesDrawn,
  };
}

function advance(app) {
  app.frameIndex = (app.frameIndex + 1) % app.motion.frames;
  const frame = app.motion.frame(app.frameIndex);
  return { frame, ...app.view(frame) };
}

// n frames one after another: each stage waited for (timed), or not.
async function timeFrames(app, n, timed) {
  const sums = Object.fromEntries([...STAGES, ...PARTS].map((s) => [s, 0]));
  let area = 0;
  const shapes = {};  // the windows' "wxh" -> frames
  const start = performance.now();
  for (let i = 0; i < n; i++) {
    const { frame, camera, box } = advance(app);
    const t = await app.player.render(frame, camera, [255, 255, 255], { timed, canvasSize: app.size, box });
    for (const s of [...STAGES, ...PARTS]) sums[s] += t[s] || 0;
    const c = app.player.lastCrop;
    area += (c.w * c.h) / (app.size * app.size);
    shapes[`${c.w}x${c.h}`] = (shapes[`${c.w}x${c.h}`] || 0) + 1;
  }
  const ms = (performance.now() - start) / n;
  return { ms_per_frame: ms, fps: 1000 / ms, stages_ms: Object.fromEntries(STAGES.map((s) => [s, sums[s] / n])),
           parts_ms: Object.fromEntries(PARTS.map((s) => [s, sums[s] / n])),
           window_share: area / n, window_shapes: shapes };
}

// n frames as the page plays them: frame t's renderer overlapping frame t+1's GL work.
async function timePlayed(app, n) {
  let k = 0;
  const start = performance.now();
  await app.player.play(() => (k++ < n ? advance(app) : null), [255, 255, 255], app.size);
  const ms = (performance.now() - start) / n;
  return { ms_per_frame: ms, fps: 1000 / ms };
}

// The person's window against the whole frame, alternating frame by frame.
async function compareCrop(app, n) {
  const margin = app.player.cropMargin, runs = { window: [], whole: [] };
  for (let i = 0; i < 2 * n + 4; i++) {
    const kind = i % 2 ? 'whole' : 'window';
    app.player.cropMargin = kind === 'whole' ? -1 : margin;
    const { frame, camera, box } = advance(app);
    const t = await app.player.render(frame, camera, [255, 255, 255], { timed: true, canvasSize: app.size, box });
    if (i >= 4) runs[kind].push({ ...t, total: STAGES.reduce((a, s) => a + t[s], 0) });
  }
  app.player.cropMargin = margin;
  const median = (xs) => { const v = [...xs].sort((a, b) => a - b); return v[v.length >> 1]; };
  const summary = (rs) => Object.fromEntries([...STAGES, 'show', 'total'].map((s) => [s, { median: median(rs.map((r) => r[s])), best: Math.min(...rs.map((r) => r[s])) }]));
  return { size: app.size, frames: n, margin, window: summary(runs.window), whole: summary(runs.whole) };
}

// A player option (player.js, setOption), the renderer graph's form (graph=NAME plays ./graph/NAME.onnx,
// served beside the folder by `morf bench web --compare graph:A,B`), or spin=on|off (renderer.js).
async function setOption(app, key, value) {
  if (key === 'spin') {  // spin:on,off: onnxruntime's idle threads spinning or sleeping (renderer.js)
    app.player.renderer.spinning = value === 'on';
    return;
  }
  if (key !== 'graph') return app.player.setOption(key, value);
  const renderer = app.player.renderer;
  if (!renderer.graphs.has(value)) {
    const response = await fetch(`./graph/${value}.onnx`);
    if (!response.ok) throw new Error(`./graph/${value}.onnx: HTTP ${response.status}`);
    renderer.addGraph(value, new Uint8Array(await response.arrayBuffer()));
  }
  renderer.useGraph(value);
}

// Two settings of one player option (player.js, setOption; or the renderer graph's form), alternating in blocks of `block`
// frames (the same load falls on both): per-stage times of each, and the wall time per frame of
// each block after its first frame (played: the frames as the page plays them, wall times only) (what a setting leaves to the browser's other threads, e.g. the
// canvas's presentation, falls on the frames after it).
async function compareOption(app, n, key, values, block, timed, played) {
  const runs = Object.fromEntries(values.map((v) => [v, []])), walls = Object.fromEntries(values.map((v) => [v, []]));
  for (let b = 0; b < 2 * Math.ceil(n / block) + 2; b++) {
    const value = values[b % 2];
    await setOption(app, key, value);
    let start = 0;
    if (played) {  // as the page plays (player.play): the block's wall time alone, and the browser's CPU time
      await timePlayed(app, 1);
      if (b >= 2) await mark(`${value}.${b}`);
      start = performance.now();
      await timePlayed(app, block);
      if (b >= 2) await mark(`${value}.${b}.end`);
    } else {
      for (let i = 0; i < block + 1; i++) {
        if (i === 1) start = performance.now();
        const { frame, camera, box } = advance(app);
        const t = await app.player.render(frame, camera, [255, 255, 255], { timed, canvasSize: app.size, box });
        if (b >= 2 && i >= 1) runs[value].push({ ...t, total: STAGES.reduce((a, s) => a + t[s], 0) });
      }
    }
    if (b >= 2) walls[value].push((performance.now() - start) / block);
  }
  const median = (xs) => { const v = [...xs].sort((a, b) => a - b); return v[v.length >> 1]; };
  const stat = (xs) => ({ median: median(xs), best: Math.min(...xs) });
  const summary = (rs, ws) => ({ ...(rs.length ? Object.fromEntries([...STAGES, 'show', 'total'].map((s) => [s, stat(rs.map((r) => r[s]))])) : {}), wall: stat(ws), frames: ws.length * block });
  return { size: app.size, frames: n, key, block, timed, played, ...Object.fromEntries(values.map((v) => [v, summary(runs[v], walls[v])])) };
}

// profile=1: N frames, each stage waited for, with onnxruntime's profiler on; the console lines
// it writes (its per-node events) come back as `profile`.
async function profileFrames(app, n) {
  const lines = [], kept = {};
  for (const level of ['log', 'info', 'debug']) {
    kept[level] = console[level];
    console[level] = (...args) => { lines.push(args.join(' ')); };
  }
  try {
    await timeFrames(app, n, true);
    for (const s of app.player.renderer.sessions.values()) await (await s).endProfiling();
  } finally {
    Object.assign(console, kept);
  }
  return { profile: lines };
}

async function bench(app, params) {
  const n = Number(params.get('bench')) || 60;
  app.playing = false;
  if (params.get('profile') === '1') return await profileFrames(app, n);
  const compare = params.get('compare');
  if (compare === 'crop') return { compare: await compareCrop(app, n) };
  if (compare) {  // compare=KEY:A,B (player.setOption), block=N frames each turn, untimed=1: stages not waited for
    const [key, values] = compare.split(':');
    if (key === 'canvas' || key === 'path') {  // both canvases on the page, each sized to the output
      const g = app.player.gl.canvas;
      g.width = g.height = app.size;
      if (!g.isConnected) document.querySelector('main').append(g);
    }
    await timeFrames(app, 3, false);
    return { compare: await compareOption(app, n, key, values.split(','), Number(params.get('block')) || 1, !params.get('untimed'),
                                          !!params.get('played')) };
  }
  await timeFrames(app, 5, false);  // warm-up: sessions, shader compilation
  await timePlayed(app, 5);
  if (params.get('fine')) app.player.compositor.fine = {};
  const staged = await timeFrames(app, n, true);
  const fine = app.player.compositor.fine;
  if (fine) for (const k of Object.keys(fine)) fine[k] /= n;
  app.player.compositor.fine = null;
  const sequential = await timeFrames(app, n, false);
  await mark('played');
  const played = await timePlayed(app, n);
  await mark('played_end');
  const mesh = meshNow(app);
  const total = STAGES.reduce((a, s) => a + staged.stages_ms[s], 0);
  const shares = Object.fromEntries(STAGES.map((s) => [s, staged.stages_ms[s] / total]));
  const result = { size: app.size, frames: n, ...played, sequential_fps: sequential.fps, staged_fps: staged.fps,
                   stages_ms: staged.stages_ms, parts_ms: staged.parts_ms, shares, fine, proxy: app.runtime.proxy, mesh_drawn: mesh,
                   window: { margin: app.player.cropMargin, share: staged.window_share, shapes: staged.window_shapes } };
  if (params.get('noadapt')) return result;
  // The adaptive size: what the page picks from the rate it measures while playing, then the rate there.
  const steps = [];
  let why = 'still changing after 6 steps';
  app.fixed = false;
  for (let round = 0; round < 6; round++) {
    await timePlayed(app, 3);
    const m = await timePlayed(app, 20);
    app.sizeFrames = Infinity;  // adapt() judges only a size it has seen for a while
    const before = app.size;
    if (!app.adapt(m.fps)) {
      why = app.output.why(m.fps, performance.now());
      break;
    }
    steps.push({ from: before, fps: m.fps, to: app.size });
  }
  await timePlayed(app, 5);
  await mark('adaptive');
  const adaptive = await timePlayed(app, n);
  await mark('adaptive_end');
  return { ...result, adaptive: { size: app.size, steps, why, ...adaptive, mesh_drawn: meshNow(app) } };
}

// The mesh the last frame drew, its triangles, and how the page chooses (mesh_choice "auto": by the
// scale the body is drawn at, pixels_per_metre).
function meshNow(app) {
  const p = app.player;
  return { mesh: p.raster.meshKind, triangles: p.raster.indexCount / 3, mesh_choice: p.meshChoice,
           pixels_per_metre: p.pixelsPerMetre ?? null };
}

async function check(app) {
  const request = await (await fetch('./check.json')).json();
  const images = [];
  app.playing = false;
  app.player.keepOutputs = !!request.outputs;  // the graph's outputs too (debugging)
  if (request.raster) app.player.cropMargin = -1;  // the whole frame's raster, as the Python player's
  for (const f of request.frames) {
    if (app.size !== f.size) app.setSize(f.size);
    await app.player.render(Float32Array.from(f.pose), f.camera, request.background, { canvasSize: f.size });
    const item = { size: f.size, rgba: base64(app.player.compositor.readImage()), window: app.player.lastCrop };
    if (request.raster) {  // the renderer's input and the bone rows too
      item.raster = base64(app.player.raster.bytes);
      item.bones = Array.from(app.player.rows);
      if (request.outputs) item.outputs = Object.fromEntries(Object.entries(app.player.lastOutputs).map(([k, t]) => [k, { dims: t.dims, type: t.type,
        data: base64(new Uint8Array(t.data.buffer, t.data.byteOffset, t.data.byteLength)) }]));
    }
    images.push(item);
  }
  return { images };
}

async function report(app, params) {
  const n = Number(params.get('report')) || 10;
  const shown = [];
  let canvas = null, image = null;
  await new Promise((resolve) => {
    app.onFrame = async () => {
      shown.push(app.frameIndex);
      if (shown.length >= n || !app.playing) {
        app.onFrame = null;
        // what the canvas shows (read in the task that drew it) and the image it was drawn from
        canvas = document.getElementById('view').toDataURL('image/png');
        image = base64(app.player.compositor.readImage());
        resolve();
      }
    };
    app.dirty = true;
    app.loop();
  });
  return {
    frames: shown, motion: app.motion.name, size: app.size, playing: app.playing, image, canvas,
    window: app.player.lastCrop, adapted: app.adapted || null,
    status: document.getElementById('status').textContent, notice: document.getElementById('notice').textContent,
    fps_text: document.getElementById('fps').textContent, motions: app.doc.motions.map((m) => m.name),
  };
}

function policy(app, params) {
  const output = new OutputSize(app.sizes, app.sizes[0], app.output.target);
  const steps = JSON.parse(params.get('policy')).map(([fps, frames, now]) => {
    const size = output.size;
    return { size, step: output.observe(fps, frames, now) };
  });
  return { sizes: app.sizes, target: output.target, steps };
}

export async function runHarness(app, params, messages) {
  let result;
  try {
    if (params.has('policy')) result = policy(app, params);
    else if (params.has('bench')) result = await bench(app, params);
    else if (params.has('check')) result = await check(app);
    else result = await report(app, params);
  } catch (e) {
    result = { error: `${e && e.stack ? e.stack : e}` };
  }
  await post({ ...result, ...environment(app), messages });
}
