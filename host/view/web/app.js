// The voxcap viewer: the hull as instanced voxels, the skeleton, the cameras as frusta, the volume and
// the floor (three.js, orbit controls); per camera its silhouette preview and 2D features; node health
// and stage timings; recording and replay. State for tests and scripts: window.voxcap.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/OrbitControls.js';
import { T, decode, rleRuns } from './protocol.js';

const state = window.voxcap = { connected: false, frames: 0, hulls: 0, poses: 0, seq: 0, voxels: 0, rendered: 0,
  joints: [], hello: null, nodes: [], stages: [], sessions: [], recording: null, replay: null, silhouettes: 0,
  mode: 'live', background: [0x15, 0x18, 0x1d] };
const $ = (id) => document.getElementById(id);
const FEATURE_COLORS = ['#ffd54f', '#4fc3f7', '#ff8a65', '#81c784', '#ba68c8'];

// ---- 3D scene ----
const canvas = $('canvas');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15181d);
const camera = new THREE.PerspectiveCamera(45, 1, 0.05, 100);
camera.up.set(0, 0, 1);
camera.position.set(4.5, -5.5, 3.2);
const controls = new OrbitControls(camera, canvas);
controls.target.set(0, 0, 1);
controls.update();
scene.add(new THREE.HemisphereLight(0xdfe8ff, 0x30343a, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(3, -4, 6);
scene.add(sun);
const world = new THREE.Group();
scene.add(world);

let voxelMesh = null, voxelCap = 0, grid = null;
// The hull is see-through so the skeleton inside it shows; the skeleton is drawn last, on top.
const voxelMaterial = new THREE.MeshLambertMaterial({ color: 0x6fa8dc, transparent: true, opacity: 0.35, depthWrite: false });
const boneMaterial = new THREE.LineBasicMaterial({ color: 0xffcc33, depthTest: false, linewidth: 2 });
const jointMaterial = new THREE.MeshBasicMaterial({ color: 0xff5533, depthTest: false });
let skeleton = null, jointMeshes = [], featureMeshes = [];

function resize() {
  const r = canvas.parentElement.getBoundingClientRect();
  renderer.setSize(r.width, r.height, false);
  camera.aspect = r.width / Math.max(1, r.height);
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);

function setupRig(h) {
  world.clear();
  grid = h.grid;
  const [x0, y0, z0] = h.grid.min_m, v = h.grid.voxel_m;
  const size = [h.grid.nx * v, h.grid.ny * v, h.grid.nz * v];
  const box = new THREE.Box3(new THREE.Vector3(x0, y0, z0), new THREE.Vector3(x0 + size[0], y0 + size[1], z0 + size[2]));
  world.add(new THREE.Box3Helper(box, 0x4fb3ff));
  const floor = new THREE.GridHelper(Math.max(8, 2 * Math.max(size[0], size[1])), 16, 0x3a4452, 0x262d36);
  floor.rotation.x = Math.PI / 2;
  world.add(floor);
  world.add(new THREE.AxesHelper(0.5));
  controls.target.set(x0 + size[0] / 2, y0 + size[1] / 2, z0 + size[2] / 3);
  // Cameras as frusta: centre -R^T t, image corners back-projected to 0.5 m.
  for (const c of h.cameras) {
    const R = c.R_cam_from_world, t = c.t_cam_from_world, K = c.K;
    const Rt = (p) => [R[0] * p[0] + R[3] * p[1] + R[6] * p[2], R[1] * p[0] + R[4] * p[1] + R[7] * p[2], R[2] * p[0] + R[5] * p[1] + R[8] * p[2]];
    const mt = Rt(t), C = [-mt[0], -mt[1], -mt[2]], d = 0.5;
    const corner = (u, v2) => { const r = Rt([(u - K[2]) / K[0] * d, (v2 - K[5]) / K[4] * d, d]); return [C[0] + r[0], C[1] + r[1], C[2] + r[2]]; };
    const q = [corner(0, 0), corner(c.width, 0), corner(c.width, c.height), corner(0, c.height)];
    const pts = [];
    for (let i = 0; i < 4; i++) pts.push(...C, ...q[i], ...q[i], ...q[(i + 1) % 4]);
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(pts, 3));
    world.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0x9aa7b8 })));
  }
  // Skeleton: bones as lines, joints as small spheres.
  const bg = new THREE.BufferGeometry();
  bg.setAttribute('position', new THREE.Float32BufferAttribute(new Float32Array(h.bones.length * 6), 3));
  skeleton = new THREE.LineSegments(bg, boneMaterial);
  skeleton.visible = false;
  skeleton.renderOrder = 10;
  world.add(skeleton);
  const sg = new THREE.SphereGeometry(0.03, 12, 8);
  jointMeshes = h.joints.map(() => { const m = new THREE.Mesh(sg, jointMaterial); m.visible = false; m.renderOrder = 11; world.add(m); return m; });
  featureMeshes = h.features.map((_, i) => { const m = new THREE.Mesh(new THREE.SphereGeometry(0.045, 12, 8), new THREE.MeshBasicMaterial({ color: FEATURE_COLORS[i % 5], wireframe: true })); m.visible = false; world.add(m); return m; });
  voxelMesh = null; voxelCap = 0;
  buildCameraPanels(h);
  redraw();
  $('legend').textContent = `${h.cameras.length} cameras · grid ${h.grid.nx}×${h.grid.ny}×${h.grid.nz} @ ${(v * 1000).toFixed(0)} mm`;
}

// The hull: decode the RLE into a bitset, draw only voxels with an empty face-neighbour (the surface).
function showHull(m) {
  if (!grid || !(m.flags & 1)) return;
  const { nx, ny, nz, voxel_m: v, min_m } = grid, n = nx * ny * nz;
  if (m.voxels !== n) return;
  const bits = new Uint8Array(n);
  rleRuns(m.rle, (s, len) => bits.fill(1, s, Math.min(n, s + len)));
  const surface = [];
  const sxy = nx * ny;
  for (let i = 0; i < n; i++) {
    if (!bits[i]) continue;
    const x = i % nx, y = ((i / nx) | 0) % ny, z = (i / sxy) | 0;
    if (x === 0 || x === nx - 1 || y === 0 || y === ny - 1 || z === 0 || z === nz - 1 ||
        !bits[i - 1] || !bits[i + 1] || !bits[i - nx] || !bits[i + nx] || !bits[i - sxy] || !bits[i + sxy]) surface.push(i);
  }
  if (!voxelMesh || surface.length > voxelCap) {
    if (voxelMesh) { world.remove(voxelMesh); voxelMesh.dispose(); }
    voxelCap = Math.max(1024, Math.ceil(surface.length * 1.5));
    voxelMesh = new THREE.InstancedMesh(new THREE.BoxGeometry(v * 0.92, v * 0.92, v * 0.92), voxelMaterial, voxelCap);
    voxelMesh.frustumCulled = false;
    world.add(voxelMesh);
  }
  const mat = new THREE.Matrix4();
  for (let k = 0; k < surface.length; k++) {
    const i = surface[k], x = i % nx, y = ((i / nx) | 0) % ny, z = (i / sxy) | 0;
    mat.makeTranslation(min_m[0] + (x + 0.5) * v, min_m[1] + (y + 0.5) * v, min_m[2] + (z + 0.5) * v);
    voxelMesh.setMatrixAt(k, mat);
  }
  voxelMesh.count = surface.length;
  voxelMesh.instanceMatrix.needsUpdate = true;
  redraw();
  state.hulls++; state.seq = m.seq; state.voxels = m.occupied; state.rendered = surface.length;
  state.latency_ms = m.latency_ms;
}

function showPose(m) {
  if (!skeleton) return;
  const pos = skeleton.geometry.attributes.position;
  state.hello.bones.forEach(([a, b], k) => { pos.setXYZ(2 * k, ...m.joints[a]); pos.setXYZ(2 * k + 1, ...m.joints[b]); });
  pos.needsUpdate = true;
  skeleton.geometry.computeBoundingSphere();
  skeleton.visible = true;
  redraw();
  m.joints.forEach((p, j) => { if (jointMeshes[j]) { jointMeshes[j].position.set(...p); jointMeshes[j].visible = true; } });
  state.joints = m.joints; state.poses++; state.pose_state = m.state;
}

function showFeatures3D(m) {
  featureMeshes.forEach((f) => (f.visible = false));
  for (const f of m.features) if (f.state === 0 && featureMeshes[f.id]) { featureMeshes[f.id].position.set(...f.p); featureMeshes[f.id].visible = true; }
}

// ---- camera panels ----
const panels = new Map();
function buildCameraPanels(h) {
  const box = $('cameras');
  box.innerHTML = '';
  panels.clear();
  for (const c of h.cameras) {
    const div = document.createElement('div');
    div.className = 'cam';
    const cv = document.createElement('canvas');
    cv.width = 160; cv.height = Math.round(160 * c.height / c.width);
    const label = document.createElement('div');
    label.className = 'label';
    label.innerHTML = `<span>${c.name} · ${c.node || '?'}</span><span class="info">no preview yet</span>`;
    div.append(cv, label);
    box.append(div);
    const g = cv.getContext('2d');
    g.fillStyle = '#0b0d10'; g.fillRect(0, 0, cv.width, cv.height);
    panels.set(c.index, { cv, g, cam: c, mask: null, features: [], info: label.querySelector('.info') });
  }
}
function drawPanel(p) {
  const { cv, g, cam } = p;
  g.fillStyle = '#0b0d10'; g.fillRect(0, 0, cv.width, cv.height);
  if (p.mask) g.drawImage(p.mask, 0, 0, cv.width, cv.height);
  const sx = cv.width / cam.width, sy = cv.height / cam.height;
  for (const f of p.features) {
    if (f.state === 3) continue;
    g.strokeStyle = g.fillStyle = FEATURE_COLORS[f.id % 5];
    g.beginPath(); g.arc(f.u * sx, f.v * sy, f.state === 0 ? 4 : 3, 0, 2 * Math.PI);
    f.state === 0 ? g.fill() : g.stroke();
  }
}
function showSilhouette(m) {
  const p = panels.get(m.rig_camera);
  if (!p || !m.width || !m.height) return;
  const img = new ImageData(m.width, m.height), d = img.data;
  for (let i = 3; i < d.length; i += 4) d[i] = 255;
  rleRuns(m.rle, (s, len) => { for (let i = s; i < s + len && i < m.width * m.height; i++) { d[4 * i] = 200; d[4 * i + 1] = 215; d[4 * i + 2] = 230; } });
  if (!p.mask) p.mask = document.createElement('canvas');
  p.mask.width = m.width; p.mask.height = m.height;
  p.mask.getContext('2d').putImageData(img, 0, 0);
  p.info.textContent = `seq ${m.seq} · 1/${m.scale}`;
  state.silhouettes++;
  drawPanel(p);
}
function showFeatures2D(m) {
  for (const c of m.cameras) { const p = panels.get(c.rig_camera); if (p) { p.features = c.features; drawPanel(p); } }
}

// ---- stats, recording, sessions ----
const fmt = (x, d = 1) => (x === undefined || x === null || Number.isNaN(x) ? '–' : Number(x).toFixed(d));
function showStats(j) {
  if (j.error) { state.error = j.error; $('legend').textContent = j.error; return; }
  if (j.nodes) {
    state.nodes = j.nodes;
    $('nodes').tBodies[0].innerHTML = j.nodes.map((n) => `<tr data-node="${n.name}"><td>${n.name}</td>` +
      `<td class="${n.connected ? 'ok' : 'bad'}">${n.connected ? n.state : 'offline'}</td><td>${fmt(n.fps)}</td>` +
      `<td class="${n.drops ? 'bad' : ''}">${n.drops}</td><td>${n.late}</td><td>${fmt(n.trigger_to_hull_ms, 2)} ms</td></tr>`).join('');
  }
  if (j.stages) {
    state.stages = j.stages;
    $('stages').tBodies[0].innerHTML = j.stages.map((s) => `<tr><td>${s.name}</td><td>${fmt(s.mean_ms, 2)}</td>` +
      `<td>${fmt(s.max_ms, 1)}</td><td>${s.queue}/${s.capacity}</td><td>${s.dropped}</td></tr>`).join('');
  }
  if (j.fps !== undefined) $('fps').textContent = `${fmt(j.fps)} fps · ${j.frames} frames · trigger→merged p50 ${fmt(j.trigger_to_merged_ms?.p50, 1)} ms`;
  if (j.recording) {
    state.recording = j.recording;
    $('record').classList.toggle('on', j.recording.on);
    $('record').textContent = j.recording.on ? `■ Stop (${j.recording.records})` : '● Record';
  }
  if (j.sessions) {
    const sel = $('sessions'), cur = sel.value;
    if (JSON.stringify(j.sessions) !== JSON.stringify(state.sessions)) {
      sel.replaceChildren(...j.sessions.map((s) => { const o = document.createElement('option'); o.textContent = s; return o; }));
      if (j.sessions.includes(cur)) sel.value = cur;
    }
    state.sessions = j.sessions;
  }
  state.viewer = j.viewer;
}
function showReplay(j) {
  if (j.live) { state.replay = null; state.mode = 'live'; }
  else { state.replay = j; state.mode = 'replay'; }
  $('timeline').hidden = state.mode !== 'replay';
  $('mode').textContent = state.mode === 'replay' ? `replay ${j.session}` : 'live';
  $('mode').classList.toggle('replay', state.mode === 'replay');
  if (j.frames !== undefined) {
    $('scrub').max = Math.max(0, j.frames - 1);
    if (!scrubbing) $('scrub').value = j.index;
    $('tpos').textContent = `${j.index + 1} / ${j.frames}${j.seq !== undefined ? ' · seq ' + j.seq : ''}`;
  }
  if (j.error) $('tpos').textContent = j.error;
}

// ---- the socket ----
// The classic WebSocket API has no back-pressure: a page that decoded and drew every message as it came
// would, on a slow or loaded machine, fall ever further behind the rig (the events queue up inside the
// browser, unbounded, and the recording state the page shows would be minutes old). So a message is only
// kept here as it arrives, the newest of each kind (silhouettes: per camera), and what is kept is applied
// once per drawn frame (apply()). Hello and Replay state are applied at once, in order.
let ws = null, scrubbing = false;
const send = (o) => ws && ws.readyState === 1 && ws.send(JSON.stringify(o));
const latest = new Map();  // kind -> ArrayBuffer
function apply() {
  const msgs = [...latest.values()];
  latest.clear();
  for (const buf of msgs) {
    const m = decode(buf);
    switch (m.type) {
      case T.Hull: showHull(m); state.frames++; break;
      case T.Pose: showPose(m); break;
      case T.Features3D: showFeatures3D(m); break;
      case T.Features2D: showFeatures2D(m); break;
      case T.Silhouette: showSilhouette(m); break;
      case T.Stats: showStats(m.json); break;
    }
  }
}
function connect() {
  ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => { state.connected = true; };
  ws.onclose = () => { state.connected = false; $('rig').textContent = 'disconnected — retrying'; setTimeout(connect, 1000); };
  ws.onmessage = (ev) => {
    if (typeof ev.data === 'string' || ev.data.byteLength < 4) return;
    const type = new DataView(ev.data).getUint8(0);
    state.received = (state.received || 0) + 1;
    if (type === T.Hello) {
      apply();  // what came before belongs to the rig before
      const m = decode(ev.data);
      state.hello = m.json; $('rig').textContent = `${m.json.rig} · ${m.json.nodes.length} nodes`; setupRig(m.json);
      // `voxcap view SESSION`: a recorded session alone, no rig to record from or go back to.
      const solo = m.json.mode === 'session';
      $('record').hidden = solo; $('live').hidden = solo;
    } else if (type === T.Replay) {
      showReplay(decode(ev.data).json);
    } else if (type === T.Stats && new TextDecoder().decode(new Uint8Array(ev.data, 4, Math.min(12, ev.data.byteLength - 4))).startsWith('{"error"')) {
      showStats(decode(ev.data).json);  // a reply to this page's request: never replaced by the next tick
    } else {
      const key = type === T.Silhouette && ev.data.byteLength >= 18 ? `6:${new DataView(ev.data).getUint16(16, true)}` : type;
      latest.set(key, ev.data);
      schedule();
    }
  };
}
$('record').onclick = () => send({ cmd: 'record', on: !(state.recording && state.recording.on) });
$('replay').onclick = () => { const s = $('sessions').value; if (s) send({ cmd: 'replay', session: s }); };
$('live').onclick = () => send({ cmd: 'live' });
$('play').onclick = () => send({ cmd: 'play' });
$('pause').onclick = () => send({ cmd: 'pause' });
$('stepf').onclick = () => send({ cmd: 'step', by: 1 });
$('stepb').onclick = () => send({ cmd: 'step', by: -1 });
$('scrub').oninput = () => { scrubbing = true; send({ cmd: 'seek', index: Number($('scrub').value) }); };
$('scrub').onchange = () => { scrubbing = false; };

// Drawing on demand (new data, the orbit controls, a resize): an idle page costs nothing. One
// animation frame applies the newest messages (above), then draws. A hidden page gets no animation
// frames: a timer applies its messages then, so its state stays current.
let pending = false, dirty = false;
function frame() {
  if (!pending) return;
  apply();
  if (dirty) { dirty = false; renderer.render(scene, camera); state.renders = (state.renders || 0) + 1; }
  pending = false;
}
function schedule() {
  if (pending) return;
  pending = true;
  requestAnimationFrame(frame);
  setTimeout(frame, 250);
}
function redraw() { dirty = true; schedule(); }
controls.addEventListener('change', redraw);
window.addEventListener('resize', redraw);
resize();
connect();
redraw();
