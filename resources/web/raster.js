// Neural rasterization in WebGL2, as morf/raster/neural_raster.py and its shaders do it: the
// render mesh skinned (top-8 bones) in the vertex shader or, on software WebGL, in JavaScript, the
// 16-channel uint8 neural texture (four RGBA8 textures, bilinear, clamped) written as 16 bytes
// per pixel into one RGBA32UI attachment cleared to the zero point (128). Channel 0 is never 128
// on the body (129 instead): the coverage mark the renderer graph and the tail read. Read back,
// the attachment is the renderer's (1, H, W, 16) uint8 input as it is; drawn and read inside a
// window (the person's, bounds.js), the window's (1, h, w, 16) input.

// skin "gpu": the vertex shader skins (the bone rows in a float texture: 104 matrices do not fit
// WebGL's guaranteed uniform space); "cpu": the vertices come skinned from JavaScript and the
// shader only projects them (software GL: SwiftShader's texelFetch-heavy vertex shading cost more
// than the JavaScript loop; a uniform block instead of the texture was slower still there). With
// the vertices skinned in JavaScript the faces turned away from the camera are dropped there too
// (cull "cpu", the default; "gl": all faces drawn, GL culls): SwiftShader's cost follows the
// triangles it is given, and the image is the same.
import { skinVertex } from './skinning.js';

function vertexShader(skin) {
  if (skin === 'cpu') {
    return `#version 300 es
precision highp float;
uniform mat4 u_view_proj;
in vec3 in_skinned;
in vec2 in_uv;
out vec2 v_texcoord;
void main() {
  v_texcoord = vec2(in_uv.x, 1.0 - in_uv.y);
  gl_Position = u_view_proj * vec4(in_skinned, 1.0);
}`;
  }
  return `#version 300 es
precision highp float;
precision highp int;
uniform highp sampler2D u_bones;   // RGBA32F, 3 x J: the top three rows of each skinning matrix
vec4 row(uint b, int i) { return texelFetch(u_bones, ivec2(i, int(b)), 0); }
uniform mat4 u_view_proj;          // gl_projection @ view matrix (framebuffer row 0 = image row 0)
in vec3 in_position;
in vec2 in_uv;
in uvec4 in_bones0;
in uvec4 in_bones1;
in vec4 in_weights0;
in vec4 in_weights1;
out vec2 v_texcoord;
vec4 blend(int i) {   // row i of the weighted sum of the vertex's skinning matrices (as the GL shader sums them)
  return in_weights0.x * row(in_bones0.x, i) + in_weights0.y * row(in_bones0.y, i)
       + in_weights0.z * row(in_bones0.z, i) + in_weights0.w * row(in_bones0.w, i)
       + in_weights1.x * row(in_bones1.x, i) + in_weights1.y * row(in_bones1.y, i)
       + in_weights1.z * row(in_bones1.z, i) + in_weights1.w * row(in_bones1.w, i);
}
void main() {
  vec4 p = vec4(in_position, 1.0);
  vec3 w = vec3(dot(blend(0), p), dot(blend(1), p), dot(blend(2), p));
  v_texcoord = vec2(in_uv.x, 1.0 - in_uv.y);  // texture rows are stored top first
  gl_Position = u_view_proj * vec4(w, 1.0);
}`;
}

// The fragment shader is the Python player's (resources/shaders/neural_raster_fs.glsl, copied into
// the folder by morf web), its desktop #version line turned into GLSL ES's.
export async function loadRasterShader(url = 'neural_raster_fs.glsl') {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status} (is the folder complete?)`);
  return esShader(await r.text());
}

export function esShader(src) {
  return src.replace(/^#version 330 core\s*\n/, '#version 300 es\nprecision highp float;\nprecision highp int;\n');
}

export function compile(gl, vs, fs) {
  const program = gl.createProgram();
  for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(s)}`);
    gl.attachShader(program, s);
  }
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`program: ${gl.getProgramInfoLog(program)}`);
  return program;
}

export class NeuralRaster {
  // avatar: {doc (avatar.json), texture (Uint8Array Ht*Wt*16), mesh (ArrayBuffer), rasterShader (GLSL ES source)}
  constructor(gl, avatar, skin = 'gpu') {
    this.gl = gl;
    const doc = avatar.doc, arrays = doc.mesh.arrays;
    this.J = doc.skeleton.parents.length;
    this.fs = avatar.rasterShader;
    const buffer = (name, target = gl.ARRAY_BUFFER) => {
      const a = arrays[name], count = a.shape.reduce((x, y) => x * y, 1);
      const bytes = count * { float32: 4, uint32: 4, uint16: 2, uint8: 1 }[a.type];
      const b = gl.createBuffer();
      gl.bindBuffer(target, b);
      gl.bufferData(target, new Uint8Array(avatar.mesh, a.offset, bytes), gl.STATIC_DRAW);
      return b;
    };
    this.arrays = arrays;
    this.buffers = Object.fromEntries(['rest_vertices', 'uvs', 'bone_weights', 'bone_indices'].map((k) => [k, buffer(k)]));
    this.faces = buffer('faces', gl.ELEMENT_ARRAY_BUFFER);
    this.indexCount = arrays.faces.shape[0] * 3;
    // The triangles drawn: "full" (the render mesh) or a lighter level (fewer triangles over the same
    // vertices, morf/web/light_mesh.py; doc.mesh.levels): software WebGL's raster follows the triangle count.
    const list = (name) => new Uint32Array(avatar.mesh, arrays[name].offset, arrays[name].shape[0] * 3);
    this.faceLists = { full: list('faces') };
    for (const level of doc.mesh.levels || []) this.faceLists[level.name] = list(level.array);
    this.maxIndexCount = this.indexCount;
    this.mesh = avatar.mesh;
    this.meshKind = 'full';
    this.pipelines = {};
    this.setSkin(skin);
    const t = doc.texture;
    this.textureSize = { width: t.width, height: t.height };
    this.textures = [];
    const plane = new Uint8Array(t.width * t.height * 4);
    for (let i = 0; i < 4; i++) {
      for (let k = 0; k < t.width * t.height; k++) for (let c = 0; c < 4; c++) plane[4 * k + c] = avatar.texture[16 * k + 4 * i + c];
      const tex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, t.width, t.height, 0, gl.RGBA, gl.UNSIGNED_BYTE, plane);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);  // bilinear, no mipmaps: grid_sample
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
      this.textures.push(tex);
    }
    this.bones = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.bones);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, 3, this.J);
    for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, p, gl.NEAREST);
    this.size = 0;
  }

  // skin: 'gpu' (the vertex shader skins) or 'cpu' (JavaScript skins, the shader projects).
  setSkin(skin) {
    if (skin !== 'gpu' && skin !== 'cpu') throw new Error(`skin=${skin}: the skinning runs on the "cpu" or the "gpu"`);
    this.skin = skin;
    if (!this.pipelines[skin]) this.pipelines[skin] = this.pipeline(skin);
    Object.assign(this, this.pipelines[skin]);
  }

  // mesh: 'full' or the name of one of the folder's lighter levels. A pipeline made later starts from
  // the current one (pipeline()), so only a change of level re-uploads the faces.
  setMesh(kind) {
    if (kind === this.meshKind) return;
    const faces = this.faceLists[kind];
    if (!faces) throw new Error(`mesh=${kind}: this avatar folder's meshes are ${Object.keys(this.faceLists).join(', ')}`);
    this.meshKind = kind;
    this.indexCount = faces.length;
    const gl = this.gl;
    gl.bindVertexArray(null);  // the element binding belongs to the bound vertex array: change none
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.faces);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, faces, gl.STATIC_DRAW);
    for (const p of Object.values(this.pipelines)) {
      if (p.skinned) p.skinned.faces = faces;
    }
  }

  pipeline(skin) {
    const gl = this.gl, arrays = this.arrays, program = compile(gl, vertexShader(skin), this.fs);
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const attr = (buffer, name, size, type, stride, offset, integer) => {
      const loc = gl.getAttribLocation(program, name);
      if (loc < 0) return;
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.enableVertexAttribArray(loc);
      if (integer) gl.vertexAttribIPointer(loc, size, type, stride, offset);
      else gl.vertexAttribPointer(loc, size, type, false, stride, offset);
    };
    const b = this.buffers;
    let skinned = null;
    attr(b.uvs, 'in_uv', 2, gl.FLOAT, 0, 0);
    if (skin === 'cpu') {
      skinned = new SkinnedVertices(arrays, this.mesh);
      skinned.front = gl.createBuffer();  // the faces facing the camera, chosen in JavaScript each frame
      skinned.faces = this.faceLists[this.meshKind];
      skinned.kept = new Uint32Array(this.maxIndexCount);
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, skinned.front);
      gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, this.maxIndexCount * 4, gl.STREAM_DRAW);
      skinned.buffer = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, skinned.buffer);
      gl.bufferData(gl.ARRAY_BUFFER, skinned.positions.byteLength, gl.STREAM_DRAW);
      attr(skinned.buffer, 'in_skinned', 3, gl.FLOAT, 0, 0);
    } else {
      attr(b.rest_vertices, 'in_position', 3, gl.FLOAT, 0, 0);
      attr(b.bone_weights, 'in_weights0', 4, gl.FLOAT, 32, 0);
      attr(b.bone_weights, 'in_weights1', 4, gl.FLOAT, 32, 16);
      const wide = arrays.bone_indices.type === 'uint16', it = wide ? gl.UNSIGNED_SHORT : gl.UNSIGNED_BYTE, n = wide ? 2 : 1;
      attr(b.bone_indices, 'in_bones0', 4, it, 8 * n, 0, true);
      attr(b.bone_indices, 'in_bones1', 4, it, 8 * n, 4 * n, true);
    }
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, skin === 'cpu' ? skinned.front : this.faces);
    gl.bindVertexArray(null);
    const u = {};
    for (const name of ['u_bones', 'u_view_proj', 'u_texture0', 'u_texture1', 'u_texture2', 'u_texture3']) {
      u[name] = gl.getUniformLocation(program, name);
    }
    return { program, vao, u, skinned };
  }

  // Two framebuffers used in turn: a frame's attachment and read-back stay intact while the next
  // frame draws (the player overlaps frame t's renderer with frame t+1's raster).
  resize(size) {
    const gl = this.gl;
    if (this.size === size) return;
    for (const t of this.targets || []) {
      gl.deleteFramebuffer(t.fbo); gl.deleteTexture(t.attachment); gl.deleteRenderbuffer(t.depth);
    }
    this.size = size;
    this.targets = [0, 1].map(() => {
      const attachment = gl.createTexture();
      gl.activeTexture(gl.TEXTURE7);
      gl.bindTexture(gl.TEXTURE_2D, attachment);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32UI, size, size);
      for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, p, gl.NEAREST);
      const depth = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, size, size);
      const fbo = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, attachment, 0);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
      const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
      if (status !== gl.FRAMEBUFFER_COMPLETE) throw new Error(`the RGBA32UI raster framebuffer is incomplete (${status})`);
      const pixels = new Uint32Array(size * size * 4);
      return { fbo, attachment, depth, pixels, bytes: new Uint8Array(pixels.buffer) };  // bytes: the (1, h, w, 16) input
    });
    this.turn = 0;
  }

  get current() { return this.targets[this.turn]; }
  get attachment() { return this.current.attachment; }
  get bytes() { return this.current.view || this.current.bytes; }  // the last read-back

  uploadBones(rows) {  // rows: Float32Array(J * 12)
    const gl = this.gl;
    if (this.skin === 'cpu') {
      gl.bindBuffer(gl.ARRAY_BUFFER, this.skinned.buffer);
      gl.bufferSubData(gl.ARRAY_BUFFER, 0, this.skinned.skin(rows));
    } else {
      gl.activeTexture(gl.TEXTURE7);
      gl.bindTexture(gl.TEXTURE_2D, this.bones);
      gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, 3, this.J, gl.RGBA, gl.FLOAT, rows);
    }
  }

  // crop: {x, y, w, h} the window drawn (rows top first; the attachment keeps image row 0 in its row
  // 0), or the whole frame. Outside it the attachment keeps what it held: read() reads only the window.
  // Replace channels 0-3 (the first texture) with these RGBA bytes (view colours, view_colours.js).
  setColour(rgba) {
    const gl = this.gl, t = this.textureSize;
    gl.bindTexture(gl.TEXTURE_2D, this.textures[0]);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, t.width, t.height, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
  }

  draw(viewProj, crop = { x: 0, y: 0, w: this.size, h: this.size }) {
    const gl = this.gl;
    this.turn ^= 1;
    this.current.crop = crop;
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.current.fbo);
    gl.viewport(0, 0, this.size, this.size);
    gl.enable(gl.SCISSOR_TEST);
    gl.scissor(crop.x, crop.y, crop.w, crop.h);
    gl.useProgram(this.program);
    gl.uniformMatrix4fv(this.u.u_view_proj, false, viewProj);
    if (this.skin === 'gpu') {
      gl.activeTexture(gl.TEXTURE4);
      gl.bindTexture(gl.TEXTURE_2D, this.bones);
      gl.uniform1i(this.u.u_bones, 4);
    }
    this.textures.forEach((tex, i) => {
      gl.activeTexture(gl.TEXTURE0 + i);
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.uniform1i(this.u[`u_texture${i}`], i);
    });
    gl.disable(gl.BLEND);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    gl.depthMask(true);
    // Back faces are culled (hidden on the closed body); the y flip of the projection turns the
    // mesh's counter-clockwise front faces clockwise.
    gl.enable(gl.CULL_FACE);
    gl.frontFace(gl.CW);
    gl.cullFace(gl.BACK);
    gl.clearBufferuiv(gl.COLOR, 0, new Uint32Array([0x80808080, 0x80808080, 0x80808080, 0x80808080]));
    gl.clearBufferfv(gl.DEPTH, 0, new Float32Array([1]));
    gl.bindVertexArray(this.vao);
    let count = this.indexCount;
    if (this.skin === 'cpu') {
      const sk = this.skinned, all = this.cull === 'gl';
      if (!all || !sk.allSet) count = all ? sk.all(count) : sk.frontFaces(viewProj);
      if (!all || !sk.uploaded) gl.bufferSubData(gl.ELEMENT_ARRAY_BUFFER, 0, sk.kept, 0, count);
      sk.uploaded = all;
    }
    gl.drawElements(gl.TRIANGLES, count, gl.UNSIGNED_INT, 0);
    gl.bindVertexArray(null);
    gl.disable(gl.CULL_FACE);
    gl.disable(gl.DEPTH_TEST);
    gl.disable(gl.SCISSOR_TEST);
  }

  // Waits for the draw (one pixel read), for stage timings only.
  sync() {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.current.fbo);
    gl.readPixels(0, 0, 1, 1, gl.RGBA_INTEGER, gl.UNSIGNED_INT, new Uint32Array(4));
  }

  read() {  // the last draw's window -> its (1, h, w, 16) uint8 bytes (a view valid until the frame after next)
    const gl = this.gl, t = this.current, c = t.crop, n = c.w * c.h * 4;
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbo);
    const pixels = t.pixels.subarray(0, n);
    gl.readPixels(c.x, c.y, c.w, c.h, gl.RGBA_INTEGER, gl.UNSIGNED_INT, pixels);
    t.view = t.bytes.subarray(0, 4 * n);
    return t.view;
  }
}

// The render mesh skinned on the CPU (skin = 'cpu'): the same top-8 linear blend as the vertex shader.
class SkinnedVertices {
  constructor(arrays, mesh) {
    const n = arrays.rest_vertices.shape[0];
    this.n = n;
    this.rest = new Float32Array(mesh, arrays.rest_vertices.offset, 3 * n);
    this.weights = new Float32Array(mesh, arrays.bone_weights.offset, 8 * n);
    const Index = arrays.bone_indices.type === 'uint16' ? Uint16Array : Uint8Array;
    this.bones = new Index(mesh, arrays.bone_indices.offset, 8 * n);
    this.positions = new Float32Array(3 * n);
  }

  // The vertices the drawn faces use (the light mesh leaves more than half of them out): only those
  // are skinned and projected.
  set faces(faces) {
    this.faceList = faces;
    const seen = new Uint8Array(this.n);
    for (let i = 0; i < faces.length; i++) seen[faces[i]] = 1;
    this.used = Uint32Array.from({ length: this.n }, (_, v) => v).filter((v) => seen[v]);
    this.allSet = false;
    this.uploaded = false;
  }

  get faces() { return this.faceList; }

  skin(rows) {
    const { rest, weights, bones, positions: out, used } = this;
    for (let i = 0; i < used.length; i++) {
      const v = used[i];
      skinVertex(out, 3 * v, rows, rest, weights, bones, v);
    }
    return out;
  }

  all(n) {
    if (!this.allSet) { this.kept.set(this.faces); this.allSet = true; }
    return n;
  }

  // The faces not clearly facing away from the camera (viewProj: column-major 4x4), into this.kept;
  // returns their index count. Back faces are those GL culls (frontFace CW after the projection's y
  // flip: positive area in normalized device coordinates); one with a vertex at or behind the eye, or
  // an area under about a pixel, is left to GL to decide.
  frontFaces(m) {
    const p = this.positions, n = this.n, faces = this.faces, kept = this.kept, used = this.used;
    if (!this.ndc || this.ndc.length !== 3 * n) this.ndc = new Float32Array(3 * n);
    const ndc = this.ndc;
    this.allSet = false;
    for (let i = 0; i < used.length; i++) {
      const v = used[i];
      const X = p[3 * v], Y = p[3 * v + 1], Z = p[3 * v + 2];
      const w = m[3] * X + m[7] * Y + m[11] * Z + m[15];
      ndc[3 * v] = (m[0] * X + m[4] * Y + m[8] * Z + m[12]) / w;
      ndc[3 * v + 1] = (m[1] * X + m[5] * Y + m[9] * Z + m[13]) / w;
      ndc[3 * v + 2] = w;
    }
    let k = 0;
    for (let f = 0; f < faces.length; f += 3) {
      const a = 3 * faces[f], b = 3 * faces[f + 1], c = 3 * faces[f + 2];
      if (ndc[a + 2] > 1e-6 && ndc[b + 2] > 1e-6 && ndc[c + 2] > 1e-6) {
        const ax = ndc[a], ay = ndc[a + 1];
        const area = (ndc[b] - ax) * (ndc[c + 1] - ay) - (ndc[c] - ax) * (ndc[b + 1] - ay);
        if (area > 1e-5) continue;
      }
      kept[k] = faces[f]; kept[k + 1] = faces[f + 1]; kept[k + 2] = faces[f + 2];
      k += 3;
    }
    return k;
  }
}
