// The page (docs/web.md): a mesh and its handles, the library's deformer in WebAssembly, three.js to show and
// drag. ?mesh=<url>&handles=<url> opens a pose (defaults: the bundled human bending); window.mlsdeformPage is
// the automation interface the browser tests use.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { TransformControls } from 'three/addons/controls/TransformControls.js';
import { loadMlsdeform } from './mlsdeform.js';
import { encodeObj, encodePly, encodeHandles, InputError } from './formats.js';
import { benchmark } from './bench.js';
import { installInteraction } from './interaction.js';
import { installSplats, splatName } from './page_splats.js';
import { base64, bytesOf, fetchBytes, save } from './io.js';
import { benchmarkSplats } from './bench_splats.js';

const $ = (id) => document.getElementById(id);
const showError = (e) => {
  $('error').textContent = e ? String(e.message ?? e) : '';
};

// --- view -----------------------------------------------------------------------------------------------
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
$('view').appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x20242a);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(2, 3, 4);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
const orbit = new OrbitControls(camera, renderer.domElement);
const gizmo = new TransformControls(camera, renderer.domElement);
gizmo.setSize(0.7);
scene.add(gizmo.getHelper());
gizmo.addEventListener('dragging-changed', (e) => {
  orbit.enabled = !e.value;
  if (e.value) pushUndo();
});
const resize = () => {
  const w = window.innerWidth, h = window.innerHeight;
  renderer.setSize(w, h);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
};
window.addEventListener('resize', resize);
resize();

// --- state ----------------------------------------------------------------------------------------------
const state = { mls: null, mesh: null, handles: null, session: null, object: null, markers: [], selected: -1, group: [], frameMs: [] };
const undoStack = [], redoStack = [];
const snapshot = () => JSON.stringify(state.handles);

function options() {
  return {
    transform: $('transform').value,
    weightExponent: Number($('u').value),
    centroids: $('centroids').value,
    arapIterations: Math.max(0, Math.floor(Number($('arap').value))),
  };
}

const flat = (list) => list.flat();

/** A new session for the current mesh, handles and switches (the rest pose changed, or an option did). */
function rebuild() {
  if (state.splats) return splatPage.rebuild();
  const { mesh, handles } = state;
  const o = options();
  const session = state.mls.createSession({
    vertices: mesh.vertices,
    triangles: o.arapIterations > 0 ? mesh.triangles : null,
    points: flat(handles.points.map((p) => p.rest)),
    segmentsA: flat(handles.segments.map((s) => s.restA)),
    segmentsB: flat(handles.segments.map((s) => s.restB)),
    region: handles.region?.length ? handles.region : null,
    ...o,
  });
  state.session?.delete();
  state.session = session;
  deform();
}

/** Copies the targets into the session, deforms, and shows the result. */
function deform() {
  if (state.splats) return splatPage.deform();
  const { session, handles } = state;
  const t = session.targets;
  const k = handles.points.length, s = handles.segments.length;
  handles.points.forEach((p, i) => t.set(p.target, 3 * i));
  handles.segments.forEach((g, i) => {
    t.set(g.targetA, 3 * (k + i));
    t.set(g.targetB, 3 * (k + s + i));
  });
  const t0 = performance.now();
  session.deform();
  timed(performance.now() - t0);
  const position = state.object.geometry.attributes.position;
  position.array.set(session.output);
  position.needsUpdate = true;
  state.object.geometry.computeVertexNormals();
  state.object.geometry.computeBoundingSphere();
  placeMarkers();
}

/** Shows a deformation's time (and the mean of the last 60). */
function timed(ms) {
  state.frameMs.push(ms);
  if (state.frameMs.length > 60) state.frameMs.shift();
  const mean = state.frameMs.reduce((a, b) => a + b, 0) / state.frameMs.length;
  $('timing').textContent = `deform: ${ms.toFixed(3)} ms (mean of ${state.frameMs.length}: ${mean.toFixed(3)} ms)`;
}

/** The handles' markers at their targets: moved in place while the handles stay the same (the gizmo holds one). */
function placeMarkers() {
  const { handles } = state;
  const k = handles.points.length;
  if (state.markers.length !== k + handles.segments.length || state.markerRadius !== state.radius) {
    for (const m of state.markers) scene.remove(m);
    state.markers = [];
    state.markerRadius = state.radius;
    const r = state.radius * 0.012;
    handles.points.forEach((p, i) => {
      const m = new THREE.Mesh(new THREE.SphereGeometry(r, 16, 12), new THREE.MeshBasicMaterial());
      m.userData.handle = i;
      scene.add(m);
      state.markers.push(m);
    });
    for (let i = 0; i < handles.segments.length; ++i) {
      const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]),
        new THREE.LineBasicMaterial({ color: 0x40c4ff }));
      scene.add(line);
      state.markers.push(line);
    }
  }
  handles.points.forEach((p, i) => {
    const m = state.markers[i];
    if (m !== gizmo.object || !gizmo.dragging) m.position.fromArray(p.target);
    m.material.color.set(i === state.selected || state.group.includes(i) ? 0xffd54f : 0xff5252);
  });
  handles.segments.forEach((g, i) => {
    const position = state.markers[k + i].geometry.attributes.position;
    position.array.set(g.targetA, 0);
    position.array.set(g.targetB, 3);
    position.needsUpdate = true;
  });
  if (state.selected >= 0 && gizmo.object !== state.markers[state.selected]) gizmo.attach(state.markers[state.selected]);
}

gizmo.addEventListener('objectChange', () => {
  if (state.selected < 0) return;
  const p = gizmo.object.position;
  state.handles.points[state.selected].target = [Math.fround(p.x), Math.fround(p.y), Math.fround(p.z)];
  try {
    deform();
    showError(null);
  } catch (e) {
    showError(e);
  }
});

function select(i) {
  state.selected = i;
  if (i >= 0) gizmo.setMode('translate');
  if (i < 0) gizmo.detach();
  placeMarkers();
}

// --- opening files --------------------------------------------------------------------------------------
/** Shows a mesh with its handles (or, without, one handle at the first vertex); all or nothing. */
function open(mesh, handles, name) {
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(Float32Array.from(mesh.vertices), 3));
  geometry.setIndex(new THREE.BufferAttribute(mesh.triangles, 1));
  const object = new THREE.Mesh(geometry, new THREE.MeshStandardMaterial({ color: 0xc8b49a, roughness: 0.7, side: THREE.DoubleSide }));
  const previous = { ...state };
  Object.assign(state, { mesh, handles, object, selected: -1, group: [], splats: null });
  geometry.computeBoundingSphere();
  state.radius = geometry.boundingSphere.radius;
  try {
    rebuild();
  } catch (e) {
    Object.assign(state, previous);
    throw e;
  }
  if (previous.splats) splatPage.close(previous.splats);
  if (previous.object) scene.remove(previous.object);
  scene.add(object);
  gizmo.detach();
  undoStack.length = redoStack.length = 0;
  const c = geometry.boundingSphere.center;
  orbit.target.copy(c);
  camera.position.set(c.x, c.y, c.z + 2.8 * state.radius);
  camera.near = state.radius / 100;
  camera.far = state.radius * 100;
  camera.updateProjectionMatrix();
  $('status').textContent = `${name}: ${mesh.vertices.length / 3} vertices, ${mesh.triangles.length / 3} triangles; ` +
    `${handles.points.length} point and ${handles.segments.length} segment handles`;
}

function defaultHandles(mesh) {
  const v = Array.from(mesh.vertices.subarray(0, 3));
  return { points: [{ rest: v, target: v, vertex: 0, name: '' }], segments: [], region: [] };
}

/** A handles file read by the program's reader against the mesh: the page's handles (names are not kept). */
function readHandles(bytes, name, mesh) {
  const h = state.mls.readHandles(bytes, name, mesh.vertices);
  return {
    points: h.points.map((p) => ({ ...p, name: '' })),
    segments: h.segments.map((s) => ({ ...s, name: '' })),
    region: h.region,
  };
}

/**
 * Opens a mesh or a splat scene (and its handles file): all read by the program's readers, compiled into the
 * module; a .ply is a splat scene when the library reads one (its vertex element has rot_0, or it is compressed).
 */
async function openFiles(meshBytes, meshName, handlesBytes, handlesName) {
  const splats = splatName(meshName) || /\.ply$/i.test(meshName) ? await splatPage.read(meshBytes, meshName) : null;
  if (splats) {
    try {
      const rest = { vertices: splats.rest };
      const handles = handlesBytes ? readHandles(handlesBytes, handlesName, rest) : defaultHandles(rest);
      $('status').textContent = splatPage.open(splats, handles, meshName);
      gizmo.detach();
      undoStack.length = redoStack.length = 0;
    } catch (e) {
      if (state.splats !== splats) splats.delete();
      throw e;
    }
    return;
  }
  const mesh = state.mls.readMesh(meshBytes, meshName);
  const handles = handlesBytes ? readHandles(handlesBytes, handlesName, mesh) : defaultHandles(mesh);
  open(mesh, handles, meshName);
}

async function openDropped(files) {
  try {
    const meshFile = files.find((f) => /\.(obj|off|ply)(\.gz)?$/i.test(f.name) || splatName(f.name));
    const handlesFile = files.find((f) => /\.json$/i.test(f.name));
    const unknown = files.find((f) => f !== meshFile && f !== handlesFile);
    if (unknown)
      throw new InputError(unknown.name, 'unknown format (readable: .obj, .off, .ply, each also .gz; splats as .ply, ' +
        '.compressed.ply, .spz, .splat; and a handles file .json)');
    if (meshFile) {
      await openFiles(await bytesOf(meshFile, meshFile.name), meshFile.name,
        handlesFile && (await bytesOf(handlesFile, handlesFile.name)), handlesFile?.name);
    } else if (handlesFile) {
      const handles = readHandles(await bytesOf(handlesFile, handlesFile.name), handlesFile.name, state.mesh);
      pushUndo();
      const before = state.handles;
      state.handles = handles;
      state.selected = -1;
      try {
        rebuild();
      } catch (e) {
        state.handles = before;  // the library refused them: the page keeps the pose it had
        undoStack.pop();
        throw e;
      }
    }
    showError(null);
  } catch (e) {
    showError(e);
  }
}

$('file').addEventListener('change', (e) => openDropped([...e.target.files]));
window.addEventListener('dragover', (e) => {
  e.preventDefault();
  document.body.classList.add('dragging');
});
window.addEventListener('dragleave', () => document.body.classList.remove('dragging'));
window.addEventListener('drop', (e) => {
  e.preventDefault();
  document.body.classList.remove('dragging');
  openDropped([...e.dataTransfer.files]);
});

// --- editing ----------------------------------------------------------------------------------------------
function pushUndo() {
  undoStack.push(snapshot());
  redoStack.length = 0;
}
function restore(from, to) {
  if (!from.length) return;
  to.push(snapshot());
  const before = JSON.parse(from.pop());
  const restChanged = JSON.stringify(before.points.map((p) => p.rest)) !== JSON.stringify(state.handles.points.map((p) => p.rest));
  state.handles = before;
  state.selected = Math.min(state.selected, before.points.length - 1);
  if (state.group.length) interaction.setGroup([]);
  restChanged ? rebuild() : deform();
}
$('undo').onclick = () => restore(undoStack, redoStack);
$('redo').onclick = () => restore(redoStack, undoStack);
window.addEventListener('keydown', (e) => {
  if ((e.ctrlKey || e.metaKey) && e.key === 'z') restore(undoStack, redoStack);
  if ((e.ctrlKey || e.metaKey) && e.key === 'y') restore(redoStack, undoStack);
});
for (const id of ['transform', 'u', 'centroids', 'arap'])
  $(id).addEventListener('change', () => {
    try {
      rebuild();
      showError(null);
    } catch (e) {
      showError(e);
    }
  });

const splatPage = installSplats({ state, scene, camera, renderer, orbit, options, timed, placeMarkers });
const interaction = installInteraction({
  state, scene, camera, renderer, gizmo, orbit, rebuild, deform, pushUndo, select, showError, placeMarkers,
  pickSplat: splatPage.pick,
  undoLast: () => (state.handles = JSON.parse(undoStack.pop())),
});

// --- export -----------------------------------------------------------------------------------------------
const exportObj = () => {
  if (state.splats) throw new Error('OBJ has no place for splats: export PLY or SPZ');
  return encodeObj(state.mesh, state.session.output);
};
const exportHandles = () => encodeHandles(state.handles.points, state.handles.segments, state.handles.region);
const saving = (f) => async () => {
  try {
    await f();
    showError(null);
  } catch (e) {
    showError(e);
  }
};
$('export-obj').onclick = saving(() => save(exportObj(), 'posed.obj'));
$('export-handles').onclick = saving(() => save(exportHandles(), 'handles.json'));
$('export-ply').onclick = saving(async () =>
  save(state.splats ? await splatPage.exportFile('ply') : encodePly(state.mesh, state.session.output), 'posed.ply'));
$('export-spz').onclick = saving(async () => save(await splatPage.exportFile('spz'), 'posed.spz'));

// --- start ------------------------------------------------------------------------------------------------
let frames = 0, fpsStart = performance.now();
function loop() {
  orbit.update();
  renderer.render(scene, camera);
  ++frames;
  requestAnimationFrame(loop);
}

const ready = (async () => {
  state.mls = await loadMlsdeform();
  const params = new URLSearchParams(location.search);
  const meshUrl = params.get('mesh') ?? 'human_man.obj';
  const handlesUrl = params.get('handles') ?? (params.has('mesh') ? null : 'human_bend.json');
  await openFiles(await fetchBytes(meshUrl), meshUrl, handlesUrl && (await fetchBytes(handlesUrl)), handlesUrl);
  requestAnimationFrame(loop);
})();
ready.catch((e) => {
  $('status').textContent = 'failed to open';
  showError(e);
});

window.mlsdeformPage = {
  ready,
  exportObj,
  exportHandles,
  /** Frames rendered per second since the last call (the display rate while something is dragged). */
  renderRate() {
    const now = performance.now(), rate = (1000 * frames) / (now - fpsStart);
    frames = 0;
    fpsStart = now;
    return rate;
  },
  /** Moves point handle i's target to xyz and deforms, as a drag does. */
  moveHandle(i, xyz) {
    state.handles.points[i].target = xyz.map(Math.fround);
    deform();
  },
  handleCount: () => state.handles.points.length,
  /** The posed splat scene's file ('ply' or 'spz'), base64, as "export PLY" / "export SPZ" save it. */
  exportSplats: async (format) => base64(await splatPage.exportFile(format)),
  /** Adds a point handle on splat i (at its current centre), as a click on it does. */
  addSplatHandle(i) {
    const c = Array.from(state.splats.centres.subarray(3 * i, 3 * i + 3));
    state.handles.points.push({ rest: Array.from(state.mesh.vertices.subarray(3 * i, 3 * i + 3)), target: c, vertex: i, name: '' });
    rebuild();
  },
  splatCount: () => state.splats?.count ?? 0,
  /** Opens a mesh or a splat scene (and a handles file) by URL, as ?mesh=&handles= do. */
  openUrl: async (url, handlesUrl = null) =>
    openFiles(await fetchBytes(url), url, handlesUrl && (await fetchBytes(handlesUrl)), handlesUrl),
  benchmarkSplats: (opts) => benchmarkSplats(state.mls, renderer, opts),
  benchmark: (opts) => benchmark(state.mls, state.mesh, state.handles, opts),
  /** Selects point handles as a group (two or more: the gizmo rotates them about their centroid). */
  selectGroup: (members) => interaction.setGroup(members),
  camera,
  gizmo,
  state,
};
