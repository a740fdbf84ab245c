// The renderer's full-resolution tail and the composite, as WebGL passes: what the native
// player's compiled pass does (morf/export/compiled_tail.py, reference_tail). onnxruntime-web runs
// the graph only up to the tail's half-resolution tensors; per output pixel, with up() the 2x
// bilinear upsampling (half-pixel centres, clamped edges):
//   head = up(HEAD), fill = up(FILL), covered = raster byte 0 != zero point
//   colour = (bytes 0-2 - zero point) * colour_scale + (covered ? 0 : fill.rgb / max(fill.a, weight_min))
//   mask = sigmoid(head.a * logit_scale + logit_offset), held at 1 inside the coverage shrunk by opaque_margin
//   image = round(255 * ((head.rgb + colour) * mask + (1 - mask) * background / 255))
// HEAD is computed from the head stage's two tensors when the graph is cut before it (int8 graphs):
//   HEAD = weight @ leaky_relu(up(low) + (skip - skip_zero_point) * skip_scale) + bias.
// Every offscreen target keeps image row 0 in its row 0, like the rasterizer's read-back; the
// display pass flips it onto the canvas (and enlarges a close-up's box). The tail runs inside the
// frame's window (the person's, bounds.js; the renderer's outputs are the window's); the image
// shows the background outside it.
import { compile } from './raster.js';
import { CpuTail } from './cpu_tail.js';

const QUAD = `#version 300 es
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}`;

const UP = `
vec4 up4(highp sampler2D t, ivec2 p, ivec2 n) {   // 2x bilinear of an RGBA texture of n texels
  vec2 s = clamp((vec2(p) + 0.5) * 0.5 - 0.5, vec2(0.0), vec2(n - 1));
  ivec2 a = ivec2(floor(s)), b = min(a + 1, n - 1);
  vec2 f = s - vec2(a);
  vec4 r0 = mix(texelFetch(t, a, 0), texelFetch(t, ivec2(b.x, a.y), 0), f.x);
  vec4 r1 = mix(texelFetch(t, ivec2(a.x, b.y), 0), texelFetch(t, b, 0), f.x);
  return mix(r0, r1, f.y);
}`;

function halfPass(stage, channels, skipFloat) {
  return `#version 300 es
precision highp float;
precision highp int;
#define C ${channels}
uniform highp sampler2D u_fill;      // FILL planes: (w2, 4 * h2) R32F
uniform ivec2 u_half;                // (w2, h2)
${stage ? `
uniform highp sampler2D u_low;       // low planes: (w4, C * h4) R32F
uniform highp ${skipFloat ? 'sampler2D' : 'usampler2D'} u_skip;  // skip planes: (w2, C * h2)
uniform vec4 u_weight[C];            // per input channel, its weight into the 4 outputs
uniform vec4 u_bias;
uniform float u_alpha, u_skip_scale, u_skip_zero_point;` : `
uniform highp sampler2D u_head;      // HEAD planes: (w2, 4 * h2) R32F`}
layout(location = 0) out vec4 head;
layout(location = 1) out vec4 fill;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  int h2 = u_half.y;
  fill = vec4(texelFetch(u_fill, p, 0).r, texelFetch(u_fill, p + ivec2(0, h2), 0).r,
              texelFetch(u_fill, p + ivec2(0, 2 * h2), 0).r, texelFetch(u_fill, p + ivec2(0, 3 * h2), 0).r);
${stage ? `
  ivec2 n = u_half / 2;
  vec2 s = clamp((vec2(p) + 0.5) * 0.5 - 0.5, vec2(0.0), vec2(n - 1));
  ivec2 a = ivec2(floor(s)), b = min(a + 1, n - 1);
  vec2 f = s - vec2(a);
  head = u_bias;
  for (int c = 0; c < C; c++) {
    int o = c * n.y;
    float r0 = mix(texelFetch(u_low, ivec2(a.x, a.y + o), 0).r, texelFetch(u_low, ivec2(b.x, a.y + o), 0).r, f.x);
    float r1 = mix(texelFetch(u_low, ivec2(a.x, b.y + o), 0).r, texelFetch(u_low, ivec2(b.x, b.y + o), 0).r, f.x);
    float v = mix(r0, r1, f.y) + (float(texelFetch(u_skip, p + ivec2(0, c * h2), 0).r) - u_skip_zero_point) * u_skip_scale;
    v = v < 0.0 ? v * u_alpha : v;
    head += v * u_weight[c];
  }` : `
  head = vec4(texelFetch(u_head, p, 0).r, texelFetch(u_head, p + ivec2(0, h2), 0).r,
              texelFetch(u_head, p + ivec2(0, 2 * h2), 0).r, texelFetch(u_head, p + ivec2(0, 3 * h2), 0).r);`}
}`;
}

const ERODE = `#version 300 es
precision highp float;
precision highp int;
uniform highp usampler2D u_raster;
uniform int u_margin;
uniform ivec2 u_lo, u_hi;           // the window's first and last pixel
uniform uint u_zero_point;
out vec4 covered;
void main() {   // the coverage's minimum over a row window (clipped to the image)
  ivec2 p = ivec2(gl_FragCoord.xy);
  float m = 1.0;
  for (int d = -u_margin; d <= u_margin; d++) {
    int x = clamp(p.x + d, u_lo.x, u_hi.x);
    m = min(m, (texelFetch(u_raster, ivec2(x, p.y), 0).r & 255u) != u_zero_point ? 1.0 : 0.0);
  }
  covered = vec4(m);
}`;

const SHADE = `#version 300 es
precision highp float;
precision highp int;
uniform highp usampler2D u_raster;
uniform highp sampler2D u_head, u_fill, u_eroded;
uniform ivec2 u_half;
uniform int u_margin;
uniform ivec2 u_lo, u_hi;           // the window's first and last pixel (HEAD and FILL cover it)
uniform uint u_zero_point;
uniform vec3 u_colour_scale, u_background;
uniform float u_logit_scale, u_logit_offset, u_weight_min;
out vec4 image;
${UP}
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  uint w = texelFetch(u_raster, p, 0).r;
  uvec3 bytes = uvec3(w & 255u, (w >> 8) & 255u, (w >> 16) & 255u);
  bool covered = bytes.x != u_zero_point;
  vec4 hd = up4(u_head, p - u_lo, u_half), fl = up4(u_fill, p - u_lo, u_half);
  vec3 colour = (vec3(bytes) - float(u_zero_point)) * u_colour_scale;
  if (!covered) colour += fl.rgb / max(fl.a, u_weight_min);
  float mask = 1.0 / (1.0 + exp(-(hd.a * u_logit_scale + u_logit_offset)));
  if (u_margin > 0) {
    float inside = 1.0;
    for (int d = -u_margin; d <= u_margin; d++) {
      inside = min(inside, texelFetch(u_eroded, ivec2(p.x, clamp(p.y + d, u_lo.y, u_hi.y)), 0).r);
    }
    mask = max(mask, inside);
  }
  vec3 c = (hd.rgb + colour) * mask + (1.0 - mask) * u_background / 255.0;
  image = vec4(clamp(round(c * 255.0), 0.0, 255.0) / 255.0, 1.0);
}`;

const DISPLAY = `#version 300 es
precision highp float;
uniform sampler2D u_image;
uniform vec4 u_box;        // the part of the image to show: x0, y0, width, height (0-1, rows top first)
uniform vec2 u_canvas;
out vec4 colour;
void main() {
  vec2 uv = gl_FragCoord.xy / u_canvas;
  uv.y = 1.0 - uv.y;       // canvas row 0 is the bottom
  colour = texture(u_image, u_box.xy + uv * u_box.zw);
}`;

function texture2D(gl, internal, w, h, filter = gl.NEAREST) {
  const t = gl.createTexture();
  gl.activeTexture(gl.TEXTURE7);  // a unit of its own: creating must not unbind what a pass reads
  gl.bindTexture(gl.TEXTURE_2D, t);
  gl.texStorage2D(gl.TEXTURE_2D, 1, internal, w, h);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, filter);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, filter);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  return t;
}

function target(gl, textures) {
  const fbo = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
  textures.forEach((t, i) => gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0 + i, gl.TEXTURE_2D, t, 0));
  gl.drawBuffers(textures.map((_, i) => gl.COLOR_ATTACHMENT0 + i));
  const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
  if (status !== gl.FRAMEBUFFER_COMPLETE) throw new Error(`a tail framebuffer is incomplete (${status})`);
  return fbo;
}

function uniforms(gl, program) {
  const u = {};
  const n = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
  for (let i = 0; i < n; i++) {
    const name = gl.getActiveUniform(program, i).name.replace(/\[0\]$/, '');
    u[name] = gl.getUniformLocation(program, name);
  }
  return u;
}

export class Compositor {
  // renderer: avatar.json's "renderer" (mode "tail" with its spec, or "image")
  // onCpu: play the tail in JavaScript (cpu_tail.js) instead of the GL passes (software WebGL).
  constructor(gl, renderer, onCpu = false) {
    this.cpu = renderer.mode === 'tail' && onCpu ? new CpuTail(renderer.tail) : null;
    if (renderer.mode === 'tail' && !this.cpu && !gl.getExtension('EXT_color_buffer_float')) {
      throw new Error('this browser cannot render into float textures (EXT_color_buffer_float), which the tail needs');
    }
    this.gl = gl;
    this.renderer = renderer;
    this.spec = renderer.tail || null;
    this.vao = gl.createVertexArray();
    this.display = compile(gl, QUAD, DISPLAY);
    this.du = uniforms(gl, this.display);
    if (this.spec && !this.cpu) {
      this.shade = compile(gl, QUAD, SHADE);
      this.su = uniforms(gl, this.shade);
      this.erode = compile(gl, QUAD, ERODE);
      this.eu = uniforms(gl, this.erode);
    }
    this.size = 0;
    this.halfProgram = null;
    this.canvas2d = null;  // a CanvasDisplay (display.js) for images made in JavaScript, or the GL canvas
  }

  resize(size) {
    const gl = this.gl;
    if (size === this.size) return;
    for (const t of this.owned || []) (t instanceof WebGLFramebuffer ? gl.deleteFramebuffer(t) : gl.deleteTexture(t));
    this.size = size;
    this.last = null;
    if (this.canvas2d) this.canvas2d.placed = null;
    this.image = texture2D(gl, gl.RGBA8, size, size, gl.LINEAR);
    this.imageFbo = target(gl, [this.image]);
    this.owned = [this.image, this.imageFbo];
    this.placed = null;
    if (this.spec && !this.cpu) {
      const h = size / 2;
      this.headTex = texture2D(gl, gl.RGBA32F, h, h);
      this.fillTex = texture2D(gl, gl.RGBA32F, h, h);
      this.halfFbo = target(gl, [this.headTex, this.fillTex]);
      this.eroded = texture2D(gl, gl.R8, size, size);
      this.erodedFbo = target(gl, [this.eroded]);
      this.planes = {};
      this.owned.push(this.headTex, this.fillTex, this.halfFbo, this.eroded, this.erodedFbo);
    }
  }

  // A planar (1, C, h, w) tensor as a (w, C * h) one-channel texture, reallocated when its shape changes.
  plane(name, tensor) {
    const gl = this.gl;
    const [, C, h, w] = tensor.dims, isFloat = tensor.data instanceof Float32Array;
    let p = this.planes[name];
    if (!p || p.w !== w || p.h !== C * h || p.isFloat !== isFloat) {
      if (p) gl.deleteTexture(p.tex);
      p = { tex: texture2D(gl, isFloat ? gl.R32F : gl.R8UI, w, C * h), w, h: C * h, isFloat };
      this.planes[name] = p;
      this.owned.push(p.tex);
    }
    gl.activeTexture(gl.TEXTURE7);  // as texture2D: uploading must not unbind what a pass reads
    gl.bindTexture(gl.TEXTURE_2D, p.tex);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, w, C * h, isFloat ? gl.RED : gl.RED_INTEGER,
                     isFloat ? gl.FLOAT : gl.UNSIGNED_BYTE, tensor.data);
    return p;
  }

  bind(unit, tex, loc) {
    const gl = this.gl;
    gl.activeTexture(gl.TEXTURE0 + unit);
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.uniform1i(loc, unit);
  }

  pass(fbo, w, h, x = 0, y = 0) {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.viewport(x, y, w, h);
    gl.bindVertexArray(this.vao);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  // Outside the window `crop` the image shows the background: cleared when the last window
  // drawn (or the background) is not inside this one.
  place(crop, background) {
    const p = this.placed, bg = background.join();
    const inside = p && p.bg === bg && crop.x <= p.x && crop.y <= p.y && crop.x + crop.w >= p.x + p.w && crop.y + crop.h >= p.y + p.h;
    this.placed = { ...crop, bg };
    if (inside || (crop.w === this.size && crop.h === this.size)) return;
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.imageFbo);
    gl.clearBufferfv(gl.COLOR, 0, Float32Array.of(background[0] / 255, background[1] / 255, background[2] / 255, 1));
  }

  // The tail over the rasterizer's attachment and the graph's outputs (name -> ort.Tensor) for the
  // window crop ({x, y, w, h}: the outputs' image area).
  composeTail(rasterTex, outputs, background, crop) {
    const gl = this.gl, s = this.spec, st = s.head_stage, hw = crop.w / 2, hh = crop.h / 2;
    this.last = null;
    this.place(crop, background);
    const mark = this.fine ? (name) => { this.sync(); const t = performance.now(); this.fine[name] = (this.fine[name] || 0) + t - this.t; this.t = t; } : () => {};
    if (this.fine) this.t = performance.now();
    const fill = this.plane('fill', outputs[s.fill]);
    if (!this.halfProgram) {
      const channels = st ? outputs[st.low].dims[1] : 4;
      this.halfProgram = compile(gl, QUAD, halfPass(!!st, channels, st && outputs[st.skip].data instanceof Float32Array));
      this.hu = uniforms(gl, this.halfProgram);
    }
    gl.useProgram(this.halfProgram);
    const u = this.hu;
    gl.uniform2i(u.u_half, hw, hh);
    this.bind(0, fill.tex, u.u_fill);
    if (st) {
      this.bind(1, this.plane('low', outputs[st.low]).tex, u.u_low);
      this.bind(2, this.plane('skip', outputs[st.skip]).tex, u.u_skip);
      const C = st.weight[0].length, wv = new Float32Array(4 * C);
      for (let c = 0; c < C; c++) for (let k = 0; k < 4; k++) wv[4 * c + k] = st.weight[k][c];
      gl.uniform4fv(u.u_weight, wv);
      gl.uniform4fv(u.u_bias, st.bias);
      gl.uniform1f(u.u_alpha, st.alpha);
      gl.uniform1f(u.u_skip_scale, st.skip_scale);
      gl.uniform1f(u.u_skip_zero_point, st.skip_zero_point);
    } else {
      this.bind(1, this.plane('head', outputs[s.head]).tex, u.u_head);
    }
    mark('upload');
    this.pass(this.halfFbo, hw, hh);
    mark('half');
    const lo = [crop.x, crop.y], hi = [crop.x + crop.w - 1, crop.y + crop.h - 1];
    if (s.opaque_margin > 0) {
      gl.useProgram(this.erode);
      this.bind(0, rasterTex, this.eu.u_raster);
      gl.uniform1i(this.eu.u_margin, s.opaque_margin);
      gl.uniform2i(this.eu.u_lo, ...lo);
      gl.uniform2i(this.eu.u_hi, ...hi);
      gl.uniform1ui(this.eu.u_zero_point, s.zero_point);
      this.pass(this.erodedFbo, crop.w, crop.h, crop.x, crop.y);
      mark('erode');
    }
    gl.useProgram(this.shade);
    const v = this.su;
    this.bind(0, rasterTex, v.u_raster);
    this.bind(1, this.headTex, v.u_head);
    this.bind(2, this.fillTex, v.u_fill);
    this.bind(3, this.eroded, v.u_eroded);
    gl.uniform2i(v.u_half, hw, hh);
    gl.uniform1i(v.u_margin, s.opaque_margin);
    gl.uniform2i(v.u_lo, ...lo);
    gl.uniform2i(v.u_hi, ...hi);
    gl.uniform1ui(v.u_zero_point, s.zero_point);
    gl.uniform3fv(v.u_colour_scale, s.colour_scale);
    gl.uniform3fv(v.u_background, background);
    gl.uniform1f(v.u_logit_scale, s.logit_scale);
    gl.uniform1f(v.u_logit_offset, s.logit_offset);
    gl.uniform1f(v.u_weight_min, s.weight_min);
    this.pass(this.imageFbo, crop.w, crop.h, crop.x, crop.y);
    mark('shade');
  }

  // The tail in JavaScript over the window's read-back raster (Uint8Array) and the graph's outputs:
  // the window's image stays in memory (this.last) until show() puts it on the canvas.
  composeCpu(raster, outputs, background, crop) {
    const s = this.spec;
    const t0 = this.fine ? performance.now() : 0;
    this.cpu.resize(crop.w, crop.h);
    this.cpu.run(raster, outputs[s.head].data, outputs[s.fill].data, background);
    if (this.fine) this.fine.js = (this.fine.js || 0) + performance.now() - t0;
    this.last = { rgba: this.cpu.rgba, pixels: this.cpu.image, crop, background, size: this.size };
  }

  // The whole graph's composited (1, h, w, 3) uint8 image of the window, as it is.
  composeImage(tensor, background, crop) {
    const rgb = tensor.data, n = crop.w * crop.h * 4;
    if (!this.rgba || this.rgba.length !== n) {
      this.rgba = new Uint8ClampedArray(n);
      this.rgbaImage = new ImageData(this.rgba, crop.w, crop.h);
    }
    const rgba = this.rgba;
    for (let i = 0, j = 0; i < rgb.length; i += 3, j += 4) {
      rgba[j] = rgb[i]; rgba[j + 1] = rgb[i + 1]; rgba[j + 2] = rgb[i + 2]; rgba[j + 3] = 255;
    }
    this.last = { rgba, pixels: this.rgbaImage, crop, background, size: this.size };
  }

  // The image onto the canvas, box: the part shown (a close-up's enlargement). An image made in
  // JavaScript goes onto the 2D canvas (display.js) when there is one, else into the GL image first.
  show(canvasSize, box = [0, 0, 1, 1]) {
    if (this.last && this.canvas2d) return this.canvas2d.show(this.last, canvasSize, box);
    if (this.last) this.upload(this.last);
    const gl = this.gl;
    if (canvasSize === this.size && box[0] === 0 && box[1] === 0 && box[2] === 1 && box[3] === 1) {
      // the image as it is, flipped upright: a copy, which software WebGL does faster than the sampling pass
      gl.bindFramebuffer(gl.READ_FRAMEBUFFER, this.imageFbo);
      gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, null);
      gl.blitFramebuffer(0, 0, this.size, this.size, 0, this.size, this.size, 0, gl.COLOR_BUFFER_BIT, gl.NEAREST);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      return;
    }
    gl.useProgram(this.display);
    this.bind(0, this.image, this.du.u_image);
    gl.uniform4fv(this.du.u_box, box);
    gl.uniform2f(this.du.u_canvas, canvasSize, canvasSize);
    this.pass(null, canvasSize, canvasSize);
  }

  upload({ rgba, crop, background }) {
    const gl = this.gl;
    this.place(crop, background);
    gl.activeTexture(gl.TEXTURE7);
    gl.bindTexture(gl.TEXTURE_2D, this.image);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, crop.x, crop.y, crop.w, crop.h, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(rgba.buffer, rgba.byteOffset, rgba.length));
  }

  // The composited image (rows top first, RGBA), for checks.
  readImage() {
    const out = new Uint8Array(this.size * this.size * 4);
    if (this.last) {  // made in JavaScript: the window over the background
      const { rgba, crop: c, background: bg, size } = this.last;
      for (let i = 0; i < size * size; i++) { out[4 * i] = bg[0]; out[4 * i + 1] = bg[1]; out[4 * i + 2] = bg[2]; out[4 * i + 3] = 255; }
      for (let y = 0; y < c.h; y++) out.set(rgba.subarray(4 * y * c.w, 4 * (y + 1) * c.w), 4 * ((c.y + y) * size + c.x));
      return out;
    }
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.imageFbo);
    gl.readPixels(0, 0, this.size, this.size, gl.RGBA, gl.UNSIGNED_BYTE, out);
    return out;
  }

  sync(canvas = false) {  // waits for the passes (one pixel read): for stage timings only
    if (this.last && (this.canvas2d || !canvas)) return;  // made in JavaScript: nothing of the GL's to wait for
    const gl = this.gl, px = new Uint8Array(4);
    gl.bindFramebuffer(gl.FRAMEBUFFER, canvas ? null : this.imageFbo);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
  }
}
