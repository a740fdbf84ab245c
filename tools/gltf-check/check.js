// Loads /avatar.glb with three.js's GLTFLoader, poses it, renders each pose into a panel of one
// canvas and posts to /result what three.js read: counts, animations, texture size, and every
// vertex's world position after skinning, twice: on the CPU (SkinnedMesh.getVertexPosition) and on
// the GPU (the same skinning shader chunks the render uses, one pixel per vertex in a float target).
//
// Query parameters: times=0,0.1,... (animation times; default: 4 spread over the first animation),
// pose=1 (also apply /pose.json: {"name", "rotations": (J, 4) xyzw, "translations": (J, 3)} in the
// skin's joint order), panel=WxH (pixels per pose).

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const BACKGROUND = [32, 48, 72];
const messages = [];
for (const level of ['warn', 'error']) {
  const original = console[level].bind(console);
  console[level] = (...args) => { messages.push(`${level}: ${args.join(' ')}`); original(...args); };
}

function base64(floats) {
  const bytes = new Uint8Array(floats.buffer, floats.byteOffset, floats.byteLength);
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

// One pixel per vertex: a tiny triangle around the pixel's centre, coloured with the vertex's
// skinned world position. Three copies of each vertex make the triangle.
const PROBE_VERTEX = `
#include <common>
#include <skinning_pars_vertex>
attribute float vid;
attribute vec2 corner;
uniform vec2 size;
varying vec3 world;
void main() {
  #include <skinbase_vertex>
  #include <begin_vertex>
  #include <skinning_vertex>
  world = (modelMatrix * vec4(transformed, 1.0)).xyz;
  vec2 pixel = vec2(mod(vid, size.x), floor(vid / size.x)) + 0.5 + corner;
  gl_Position = vec4(pixel / size * 2.0 - 1.0, 0.0, 1.0);
}`;
const PROBE_FRAGMENT = `
varying vec3 world;
void main() { gl_FragColor = vec4(world, 1.0); }`;

function gpuProbe(mesh) {
  const V = mesh.geometry.attributes.position.count;
  const width = 1024, height = Math.ceil(V / width);
  const src = mesh.geometry.attributes;
  const pos = new Float32Array(9 * V), idx = new Float32Array(12 * V), wts = new Float32Array(12 * V);
  const vid = new Float32Array(3 * V), corner = new Float32Array(6 * V);
  const offsets = [[-0.4, -0.4], [0.8, -0.4], [-0.4, 0.8]];  // covers its own pixel centre only
  for (let i = 0; i < V; i++) {
    for (let c = 0; c < 3; c++) {
      const k = 3 * i + c;
      for (let a = 0; a < 3; a++) pos[3 * k + a] = src.position.getComponent(i, a);
      for (let a = 0; a < 4; a++) {
        idx[4 * k + a] = src.skinIndex.getComponent(i, a);
        wts[4 * k + a] = src.skinWeight.getComponent(i, a);
      }
      vid[k] = i;
      corner[2 * k] = offsets[c][0];
      corner[2 * k + 1] = offsets[c][1];
    }
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  g.setAttribute('skinIndex', new THREE.BufferAttribute(idx, 4));
  g.setAttribute('skinWeight', new THREE.BufferAttribute(wts, 4));
  g.setAttribute('vid', new THREE.BufferAttribute(vid, 1));
  g.setAttribute('corner', new THREE.BufferAttribute(corner, 2));
  const material = new THREE.ShaderMaterial({
    vertexShader: PROBE_VERTEX, fragmentShader: PROBE_FRAGMENT, depthTest: false, depthWrite: false,
    blending: THREE.NoBlending, side: THREE.DoubleSide,
    uniforms: { size: { value: new THREE.Vector2(width, height) } },
  });
  const probe = new THREE.SkinnedMesh(g, material);
  probe.bind(mesh.skeleton, mesh.bindMatrix);
  probe.frustumCulled = false;
  probe.matrixAutoUpdate = false;
  const scene = new THREE.Scene();
  scene.add(probe);
  const target = new THREE.WebGLRenderTarget(width, height, { type: THREE.FloatType, format: THREE.RGBAFormat,
    minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter, depthBuffer: false });
  const camera = new THREE.Camera();
  const pixels = new Float32Array(4 * width * height);
  return (renderer) => {
    probe.matrix.copy(mesh.matrixWorld);
    probe.matrixWorld.copy(mesh.matrixWorld);
    renderer.setRenderTarget(target);
    renderer.setClearColor(0x000000, 0);
    renderer.clear();
    renderer.render(scene, camera);
    renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
    renderer.setRenderTarget(null);
    const out = new Float32Array(3 * V);
    let missing = 0;
    for (let i = 0; i < V; i++) {
      if (pixels[4 * i + 3] !== 1) missing++;
      for (let a = 0; a < 3; a++) out[3 * i + a] = pixels[4 * i + a];
    }
    return { positions: out, missing };
  };
}

function cpuPositions(mesh) {
  const V = mesh.geometry.attributes.position.count;
  const out = new Float32Array(3 * V), v = new THREE.Vector3();
  for (let i = 0; i < V; i++) {
    mesh.getVertexPosition(i, v);  // position, then applyBoneTransform: the skinned position (mesh space)
    v.applyMatrix4(mesh.matrixWorld);
    out[3 * i] = v.x; out[3 * i + 1] = v.y; out[3 * i + 2] = v.z;
  }
  return out;
}

function box(positions) {
  const b = new THREE.Box3();
  b.setFromArray(positions);
  return b;
}

async function run() {
  const params = new URLSearchParams(location.search);
  const [panelW, panelH] = (params.get('panel') || '240x400').split('x').map(Number);
  const gltf = await new GLTFLoader().loadAsync('./avatar.glb');
  const scene = gltf.scene;
  scene.updateMatrixWorld(true);
  const meshes = [], skinned = [];
  scene.traverse((o) => { if (o.isMesh) meshes.push(o); if (o.isSkinnedMesh) skinned.push(o); });
  if (!skinned.length) throw new Error('no skinned mesh in the scene');
  const mesh = skinned[0];
  const geometry = mesh.geometry;
  const V = geometry.attributes.position.count;
  const map = mesh.material.map;
  const animations = gltf.animations.map((c) => ({ name: c.name, duration: c.duration, tracks: c.tracks.length }));

  // The poses: the bind pose, the first animation at some times, then an explicit pose.
  const poses = [{ name: 'bind' }];
  const clip = gltf.animations[0];
  let times = params.get('times') ? params.get('times').split(',').map(Number) : [];
  if (clip && !params.get('times')) times = [0, 1, 2, 3].map((k) => Math.round((k * clip.duration) / 3 * 1e4) / 1e4);
  if (clip) for (const t of times) poses.push({ name: `${clip.name}@${t}`, time: t });
  let explicit = null;
  if (params.get('pose')) explicit = await (await fetch('./pose.json')).json();
  else if (!clip) {  // no animation: bend every joint a little so the skin still has work to do
    const q = new THREE.Quaternion();
    explicit = { name: 'bent', rotations: mesh.skeleton.bones.map((b, k) =>
      q.setFromAxisAngle(new THREE.Vector3(1, 0, 0), 0.15 * Math.sin(k)).clone().multiply(b.quaternion).toArray()) };
  }
  if (explicit) poses.push({ name: explicit.name || 'pose', explicit });

  const canvas = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(panelW * poses.length, panelH, false);
  const gl = renderer.getContext();
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const background = new THREE.Color().setRGB(...BACKGROUND.map((c) => c / 255), THREE.SRGBColorSpace);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 1.5));
  const sun = new THREE.DirectionalLight(0xffffff, 2.0);
  sun.position.set(1, 2, 3);
  scene.add(sun);
  const probe = gpuProbe(mesh);
  const mixer = clip ? new THREE.AnimationMixer(scene) : null;
  if (clip) {
    const action = mixer.clipAction(clip);
    action.setLoop(THREE.LoopOnce, 1);
    action.clampWhenFinished = true;  // time = duration shows the last keyframe
    action.play();
  }

  const results = [];
  const bones = mesh.skeleton.bones;
  for (const [k, pose] of poses.entries()) {
    if (pose.time !== undefined) mixer.setTime(pose.time);
    if (pose.explicit) {
      if (mixer) mixer.stopAllAction();
      pose.explicit.rotations.forEach((q, j) => bones[j].quaternion.fromArray(q));
      (pose.explicit.translations || []).forEach((t, j) => bones[j].position.fromArray(t));
    }
    scene.updateMatrixWorld(true);
    const cpu = cpuPositions(mesh);
    const gpu = probe(renderer);
    const b = box(cpu);
    const centre = b.getCenter(new THREE.Vector3()), size = b.getSize(new THREE.Vector3());
    const camera = new THREE.PerspectiveCamera(30, panelW / panelH, 0.05, 100);
    const fit = Math.max(size.y, (size.x * panelH) / panelW) * 1.15;
    camera.position.set(centre.x, centre.y, centre.z + fit / 2 / Math.tan(THREE.MathUtils.degToRad(15)));
    camera.lookAt(centre);
    renderer.setViewport(k * panelW, 0, panelW, panelH);
    renderer.setScissor(k * panelW, 0, panelW, panelH);
    renderer.setScissorTest(true);
    renderer.setClearColor(background, 1);
    renderer.clear();
    renderer.render(scene, camera);
    renderer.setScissorTest(false);
    results.push({ name: pose.name, time: pose.time ?? null, cpu: base64(cpu), gpu: base64(gpu.positions),
                   gpu_missing: gpu.missing, box_min: b.min.toArray(), box_max: b.max.toArray() });
  }
  const rest = geometry.attributes.position.array;
  const dataURL = canvas.toDataURL('image/png');
  return {
    three: THREE.REVISION,
    user_agent: navigator.userAgent,
    webgl: { version: gl.getParameter(gl.VERSION),
             renderer: info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER) },
    meshes: meshes.length, skinned_meshes: skinned.length, vertices: V,
    triangles: geometry.index ? geometry.index.count / 3 : V / 3,
    joints: bones.length, joint_names: bones.map((b) => b.name),
    animations, texture: map ? { width: map.image.width, height: map.image.height } : null,
    rest: base64(rest instanceof Float32Array ? rest : new Float32Array(rest)),
    panel: [panelW, panelH], background: BACKGROUND, poses: results,
    render_calls: renderer.info.render.calls, messages, screenshot: dataURL,
  };
}

async function post(body) {
  await fetch('./result', { method: 'POST', headers: { 'Content-Type': 'application/json' },
                            body: JSON.stringify(body) });
}

window.addEventListener('error', (e) => messages.push(`uncaught: ${e.message}`));
run().then(post).catch((e) => post({ error: `${e && e.stack ? e.stack : e}`, messages }));
