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
process.exit(failures ? 1 : 0);
