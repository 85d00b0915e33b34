// The JavaScript API (web/src/mlsdeform.js) under Node: run from build-web/site/ by tests/web.cmake (web:api).
//   node --no-experimental-fetch web/tests/api.mjs build-web/site
import { join, resolve } from 'node:path';
import { pathToFileURL } from 'node:url';

const site = resolve(process.argv[2]);
const { loadMlsdeform } = await import(pathToFileURL(join(site, 'mlsdeform.js')));
const mls = await loadMlsdeform();
const M = mls.module;
let failures = 0;
const check = (ok, what) => {
  console.log(`${ok ? 'ok' : 'FAILED'}: ${what}`);
  if (!ok) ++failures;
};
const throws = (f, pattern, what) => {
  try {
    f();
    check(false, `${what}: did not throw`);
  } catch (e) {
    check(pattern.test(e.message), `${what}: ${e.constructor.name}: ${e.message}`);
  }
};

// A cloud of 5,000 points, 6 handles, with and without triangles (a strip), each transform.
const n = 5000, vertices = new Float32Array(3 * n);
for (let i = 0; i < n; ++i) vertices.set([Math.cos(i), Math.sin(1.3 * i), (i % 97) / 97], 3 * i);
const points = [0, 1, 2, 3, 4, 5].flatMap((j) => Array.from(vertices.subarray(3 * 800 * j, 3 * 800 * j + 3)));
for (const transform of ['rigid', 'similarity', 'affine']) {
  const s = mls.createSession({ vertices, points, transform });
  const targets = s.targets, output = s.output;
  s.deform();
  // No per-frame allocation: the heap in use and the views stay the same over many frames.
  const heap = M._mls_heap_in_use();
  for (let f = 0; f < 200; ++f) {
    targets[0] = points[0] + 0.01 * Math.sin(f);
    s.deform();
  }
  check(M._mls_heap_in_use() === heap, `${transform}: 200 frames leave the heap in use at ${heap} bytes`);
  check(s.targets === targets && s.output === output, `${transform}: the views are the same objects after the frames`);
  check(output.every(Number.isFinite), `${transform}: the output is finite`);
  // A vertex on a handle follows it exactly (the library snaps it).
  const t = [0.25, -0.5, 0.125];
  targets.set(t, 3);
  s.deform();
  check(output[3 * 800] === t[0] && output[3 * 800 + 1] === t[1] && output[3 * 800 + 2] === t[2],
    `${transform}: the vertex on handle 1 is at its target`);
  s.delete();
  throws(() => s.deform(), /deleted/, `${transform}: deform() after delete()`);
}

// Errors carry the library's message; nothing leaks when a session is refused (after a first refusal, which
// gives the stored message its capacity).
throws(() => mls.createSession({ vertices, points: [] }), /handle/, 'no handles');
throws(() => mls.createSession({ vertices, points, weightExponent: 0.5 }), /weight_exponent/, 'u < 1');
throws(() => mls.createSession({ vertices, points, arapIterations: 2 }), /triangles/, 'ARAP without triangles');
throws(() => mls.createSession({ vertices, points: [0, 0] }), /multiple of 3/, 'a point without z');
throws(() => mls.createSession({ vertices, points, transform: 'shear' }), /transform/, 'an unknown transform');
const heap = M._mls_heap_in_use();
for (let k = 0; k < 20; ++k) {
  try {
    mls.createSession({ vertices, points, weightExponent: 0.5 });
  } catch {}
}
check(M._mls_heap_in_use() === heap, `20 refused sessions leave the heap in use at ${heap} bytes`);
const s = mls.createSession({ vertices, points });
s.targets[0] = NaN;
throws(() => s.deform(), /non-finite/, 'a NaN target');
s.targets[0] = points[0];
s.deform();
check(s.output.every(Number.isFinite), 'the session works after a refused frame');

// Memory growth detaches the old buffer: the session's views are remade.
const before = s.output;
const big = M._malloc(64 << 20);
check(s.output !== before && s.output.length === 3 * n, 'the views are remade after the memory grew');
M._free(big);
s.delete();

// The program's readers: a quad in OBJ and in OFF, polygons kept and fanned into triangles; errors in the
// program's words; nothing leaks when a file is refused.
const obj = mls.readMesh('# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0.5\nf 1 2 3 4\n', 'quad.obj');
check(obj.vertices.length === 12 && obj.vertices[11] === 0.5, 'readMesh: the OBJ quad\'s 4 vertices, in order');
check(JSON.stringify(obj.faces) === '[[0,1,2,3]]', `readMesh: the OBJ quad's face ${JSON.stringify(obj.faces)}`);
check(Array.from(obj.triangles).join() === '0,1,2,0,2,3', `readMesh: its fan triangles ${Array.from(obj.triangles)}`);
const off = mls.readMesh(new TextEncoder().encode('OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0.5\n4 0 1 2 3\n'), 'quad.off');
check(off.vertices.every((x, i) => x === obj.vertices[i]) && JSON.stringify(off.faces) === '[[0,1,2,3]]',
  'readMesh: the OFF quad reads as the OBJ one');
throws(() => mls.readMesh('v 0 0 0\nv 1 0 zero\n', 'bad.obj'), /^bad\.obj: line 2: .*'zero'/, 'readMesh: a word for a number');
throws(() => mls.readMesh('v 0 0 0\nv 1 0 1e39\n', 'big.obj'), /^big\.obj: line 2: number out of the range of float/,
  'readMesh: 1e39 in float');
throws(() => mls.readMesh('solid x\n', 'x.stl'), /^x\.stl: unknown mesh format/, 'readMesh: an unknown format');
const handles = mls.readHandles('{"points": [{"vertex": 1, "offset": [0, 0, 1]}, {"rest": [0.5, 0.5, 0]}]}', 'h.json', obj.vertices);
check(handles.points.length === 2 && handles.points[0].vertex === 1 && handles.points[0].target.join() === '1,0,1' &&
  handles.points[1].vertex === -1, `readHandles: ${JSON.stringify(handles.points)}`);
throws(() => mls.readHandles('{"points": [{"vertex": 9}]}', 'h.json', obj.vertices), /^h\.json: \/points\/0\/vertex: /,
  'readHandles: a vertex out of range');
const heapRead = M._mls_heap_in_use();
for (let k = 0; k < 20; ++k) {
  try {
    mls.readMesh('v 0 0 0\nv 1 0 zero\n', 'bad.obj');
  } catch {}
}
check(M._mls_heap_in_use() === heapRead, `20 refused meshes leave the heap in use at ${heapRead} bytes`);

// The batched rotation fit: H_i = R_i diag(3, 2, 1) for 1,000 random rotations R_i fits R_i. Bound: H_i rounded
// to float moves the fit by at most eps(float) ||H|| / (smallest gap of H's singular values) = 3 eps, and the fit
// itself is orthonormal to 64 eps (rotation.hpp): 64 eps x 3 with eps = 2^-24.
const fits = 1000, H = new Float32Array(9 * fits), R0 = new Float64Array(9 * fits);
for (let i = 0; i < fits; ++i) {
  let [w, x, y, z] = [Math.sin(7 * i + 1), Math.cos(3 * i), Math.sin(5 * i + 2), Math.cos(11 * i + 3)];
  const q = Math.hypot(w, x, y, z);
  [w, x, y, z] = [w / q, x / q, y / q, z / q];
  const R = [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
    2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
    2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)];
  R0.set(R, 9 * i);
  for (let r = 0; r < 3; ++r) for (let c = 0; c < 3; ++c) H[9 * i + 3 * r + c] = R[3 * r + c] * (3 - c);
}
const fitted = mls.fitRotations(H);
const fitBound = 64 * 2 ** -24 * 3;
const fitError = fitted.reduce((m, v, k) => Math.max(m, Math.abs(v - R0[k])), 0);
check(fitError <= fitBound, `fitRotations: 1,000 rotations recovered to ${fitError.toExponential(2)} <= ${fitBound.toExponential(2)}`);
const again = new Float32Array(H.length);
check(mls.fitRotations(H, again) === again && again.every((v, k) => v === fitted[k]), 'fitRotations: into `out`, the same bits');
H[9 * 7 + 5] = NaN;
throws(() => mls.fitRotations(H), /H\[7, 1, 2\]/, 'fitRotations: a NaN entry is named');
throws(() => mls.fitRotations(new Float32Array(10)), /multiple of 9/, 'fitRotations: a length that is not 9 n');
// Splat scenes (readSplats): a 3DGS PLY read, posed and packed; poses keep the heap and the views; what is no
// splat file, or a handle target that is not finite, is refused; delete() frees all of it.
const { splatScenePly } = await import(pathToFileURL(join(site, 'splat_scene.js')));
const heapSplats = M._mls_heap_in_use();
const scene = mls.readSplats(splatScenePly(3000, 2), 'scene.ply');
check(scene.count === 3000 && scene.shDegree === 2, `readSplats: ${scene.count} splats of SH degree ${scene.shDegree}`);
scene.setup({ points: [...scene.rest.subarray(0, 3), ...scene.rest.subarray(3 * 2999)] });
scene.deform();
const packedView = scene.packed, heapPose = M._mls_heap_in_use();
for (let f = 0; f < 20; ++f) {
  scene.targets[3] = scene.rest[3 * 2999] + 0.1 * Math.sin(f);
  scene.deform();
}
check(M._mls_heap_in_use() === heapPose && scene.packed === packedView, `splats: 20 poses keep the heap (${heapPose} bytes) and the views`);
check(scene.centres.every(Number.isFinite) && scene.packed.subarray(0, 4 * 3000).some((w) => w !== 0), 'splats: posed and packed');
scene.targets[0] = NaN;
throws(() => scene.deform(), /not finite/, 'splats: a NaN target');
throws(() => mls.readSplats('ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n', 'mesh.ply'),
  /not a Gaussian splat file/, 'readSplats: a PLY mesh');
throws(() => mls.readSplats(new Uint8Array(31), 'short.splat'), /short.splat/, 'readSplats: a truncated .splat');
scene.delete();
check(M._mls_heap_in_use() === heapSplats, `splats: delete() leaves the heap at ${heapSplats} bytes`);
process.exit(failures ? 1 : 0);
