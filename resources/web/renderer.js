// The avatar's renderer graph in onnxruntime-web, loaded from the folder's lib/ only (no other
// host is asked for anything). WASM with SIMD and threads; WebGPU where the browser has it and
// the folder carries that build. Threads need cross-origin isolation (the COOP/COEP headers
// `morf serve` sends); without it onnxruntime runs on one thread and the page says so.

async function inflate(url) {
  // The WASM binary is stored gzip-compressed; a host that already decoded it (Content-Encoding) hands back raw WASM.
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  const bytes = new Uint8Array(await response.arrayBuffer());
  if (bytes[0] !== 0x1f || bytes[1] !== 0x8b) return bytes.buffer;
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
  return await new Response(stream).arrayBuffer();
}

export async function loadRuntime(config, params) {
  const wanted = params.get('backend');
  const offered = Object.fromEntries(config.backends.map((b) => [b.backend, b]));
  let pick = offered.wasm;
  if ((wanted === 'webgpu' || (!wanted && 'gpu' in navigator)) && offered.webgpu) {
    try {
      if (await navigator.gpu.requestAdapter()) pick = offered.webgpu;
    } catch (e) { /* no adapter: WASM */ }
  }
  const ort = await import(`./lib/${pick.loader}`);
  ort.env.logLevel = 'error';
  ort.env.wasm.wasmBinary = await inflate(`lib/${pick.wasm}`);
  ort.env.wasm.wasmPaths = { mjs: new URL(`lib/${pick.worker}`, location.href).href };
  const isolated = self.crossOriginIsolated === true;
  const cores = navigator.hardwareConcurrency || 1;
  const asked = Number(params.get('threads')) || 0;
  ort.env.wasm.numThreads = isolated ? Math.max(1, asked || Math.min(cores, 4)) : 1;
  // proxy=1: the renderer in its own worker, leaving the page's thread to the next frame's GL work.
  // Off by default: on a busy 2-core CPU it ran 1.5-2x slower (messages, copies, one more thread).
  ort.env.wasm.proxy = pick.backend === 'wasm' && params.get('proxy') === '1';
  // profile=1 (benchmarks): onnxruntime's per-node profiler in every session (its events go to the console)
  const profile = params.get('profile') === '1';
  // spin=off: the session option that lets onnxruntime's idle threads sleep instead of spinning (on
  // a 2-core machine the spinning competes with the software WebGL's threads). onnxruntime-web 1.30
  // does not read it: its sessions share a global pool created without spin control (docs/web.md).
  const spinning = params.get('spin') !== 'off';
  return { ort, backend: pick.backend, threads: ort.env.wasm.numThreads, isolated, proxy: ort.env.wasm.proxy, profile, spinning };
}

const KEPT_SESSIONS = 6;  // window shapes whose sessions stay open, per graph (each holds its own buffers)

export class Renderer {
  constructor(runtime, graph, contract) {
    this.rt = runtime;
    this.graphs = new Map([['folder', graph]]);  // name -> ONNX bytes: the folder's, and others a comparison adds
    this.graphName = 'folder';
    this.spinning = runtime.spinning !== false;  // onnxruntime's intra-op threads spin while idle (its default)
    this.contract = contract;
    this.sessions = new Map();  // "NAME:HxW" -> Promise<session>, the most recently used last
  }

  get graph() { return this.graphs.get(this.graphName); }

  // Another form of the same graph (the same inputs and outputs), e.g. for `morf bench web --compare graph:A,B`.
  addGraph(name, bytes) { this.graphs.set(name, bytes); }

  useGraph(name) {
    if (!this.graphs.has(name)) throw new Error(`no renderer graph ${name}`);
    this.graphName = name;
  }

  session(h, w) {  // one creation per graph and shape, however many frames ask at once
    const key = `${this.graphName}:${this.spinning ? 'spin' : 'sleep'}:${h}x${w}`;
    let s = this.sessions.get(key);
    if (s) {
      this.sessions.delete(key);  // to the end: the most recently used
    } else {
      const { ort, backend } = this.rt;
      // The graph names its image dimensions "height" and "width"; fixed, the shape arithmetic folds away.
      // A copy of the graph: a proxied runtime takes over (transfers) the buffers it is given.
      s = ort.InferenceSession.create(this.graph.slice(), {
        executionProviders: [backend], graphOptimizationLevel: 'all', logSeverityLevel: 3,
        freeDimensionOverrides: { height: h, width: w }, enableProfiling: !!this.rt.profile,
        ...(this.spinning ? {} : { extra: { session: { intra_op: { allow_spinning: '0' } } } }),
      });
      if (this.sessions.size >= 2 * KEPT_SESSIONS * this.graphs.size) {  // both spinning settings
        const [oldest, old] = this.sessions.entries().next().value;
        this.sessions.delete(oldest);
        old.then((x) => x.release()).catch(() => {});
      }
    }
    this.sessions.set(key, s);
    return s;
  }

  // raster: Uint8Array of the (1, h, w, 16) input; background: [r, g, b] 0-255.
  async run(raster, h, w, background) {
    const { ort } = this.rt;
    const session = await this.session(h, w);
    const input = this.rt.proxy ? raster.slice() : raster;  // the tail still reads the raster after the run
    const feeds = { [this.contract.input]: new ort.Tensor('uint8', input, [1, h, w, 16]) };
    if (this.contract.mode === 'image') {
      feeds[this.contract.background] = new ort.Tensor('float32', Float32Array.from(background), [1, 3, 1, 1]);
    }
    return await session.run(feeds);  // every output of the graph (a compared graph may carry the colour fill)
  }
}
