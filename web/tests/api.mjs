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
process.exit(failures ? 1 : 0);
