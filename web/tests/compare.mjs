// The page's OBJ against `mlsdeform deform`'s, vertex by vertex (web/tests/browser.mjs, check `compare`).
//
// Against the program on the SSE4.2 kernels (MLSDEFORM_ISA=sse4_2) the bound is 0: the page runs the same
// SSE4.2 twins, which emscripten maps one to one onto WebAssembly SIMD (IEEE add, mul, div, sqrt, min, max,
// compares and blends: each correctly rounded, as on x86), with -ffp-contract=off on both sides, so every
// stage rounds the same values the same way. Measured: bitwise equal on the human.
//
// Against the program on the CPU's best ISA (AVX2 or AVX-512, which fuse the written-out mul_add that SSE4.2
// computes with two roundings) the bound is the native twins' own: tests/test_deformer_simd.cpp derives that two
// float paths forming q* and H from the same sums differ in their rotations by at most 128 eps kappa and
// allows 256 eps of the scene's size for well-spread handles (kappa O(1)); with |vhat| at most the bounding
// box diagonal d, the bound per vertex is 256 eps(float) d. Measured: 2.0e-7 on the human (d = 2.6).
const vertices = (text) =>
  text
    .split('\n')
    .filter((l) => l.startsWith('v '))
    .map((l) => l.split(/\s+/).slice(1, 4).map(Number));

export function compareObj(pageObj, cliObj, restObj, exact) {
  const a = vertices(pageObj), b = vertices(cliObj), rest = vertices(restObj);
  if (a.length !== b.length || a.length !== rest.length)
    throw new Error(`vertex counts differ: page ${a.length}, program ${b.length}, rest ${rest.length}`);
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (const v of rest) for (let c = 0; c < 3; ++c) (lo[c] = Math.min(lo[c], v[c])), (hi[c] = Math.max(hi[c], v[c]));
  const diagonal = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  const bound = exact ? 0 : 256 * 2 ** -23 * diagonal;
  let worst = 0, at = -1;
  for (let i = 0; i < a.length; ++i) {
    const d = Math.max(...[0, 1, 2].map((c) => Math.abs(a[i][c] - b[i][c])));
    if (!(d <= worst)) (worst = d), (at = i);
  }
  return { count: a.length, worst, bound, at };
}

// node compare.mjs PAGE_OBJ PROGRAM_OBJ REST_OBJ [exact]: exit 1 beyond the bound.
if (process.argv[1] && import.meta.url.endsWith(process.argv[1].split('/').pop())) {
  const { readFileSync } = await import('node:fs');
  const [a, b, rest, exact] = process.argv.slice(2);
  const r = compareObj(readFileSync(a, 'utf8'), readFileSync(b, 'utf8'), readFileSync(rest, 'utf8'), exact === 'exact');
  console.log(`compared ${r.count} vertices: largest difference ${r.worst.toExponential(3)} (bound ${r.bound.toExponential(3)}) at vertex ${r.at}`);
  process.exit(r.worst <= r.bound ? 0 : 1);
}
