// The page's benchmarks (docs/web.md, "Figures"): deformations per second of the library in WebAssembly, on the
// open mesh and on a synthetic cloud of 10^5 points, each frame moving the targets a little as a drag does.
// Run by web/tests/bench.mjs in headless Chromium, or from the console: await mlsdeformPage.benchmark().

/** Frames per second of `session` over at least `seconds`, the first handle's target moving each frame. */
function rate(session, seconds) {
  const t = session.targets;
  const x0 = t[0];
  session.deform();  // warm: the first frame's one-time work is not what a drag repeats
  let frames = 0;
  const start = performance.now();
  let now = start;
  while (now - start < 1000 * seconds) {
    for (let k = 0; k < 10; ++k, ++frames) {
      t[0] = x0 + 1e-3 * Math.sin(frames);
      session.deform();
    }
    now = performance.now();
  }
  t[0] = x0;
  return (1000 * frames) / (now - start);
}

/** A deterministic cloud of n points in the unit cube, and `k` of them as handles. */
function cloud(n, k) {
  let s = 12345;
  const next = () => ((s = (Math.imul(s, 1103515245) + 12345) >>> 0) / 2 ** 32);
  const v = new Float32Array(3 * n);
  for (let i = 0; i < v.length; ++i) v[i] = next();
  const points = [];
  for (let i = 0; i < k; ++i) {
    const j = Math.floor((i * n) / k);
    points.push(v[3 * j], v[3 * j + 1], v[3 * j + 2]);
  }
  return { vertices: v, points };
}

export function benchmark(mls, mesh, handles, { seconds = 2 } = {}) {
  const points = handles.points.flatMap((p) => p.rest);
  const segmentsA = handles.segments.flatMap((s) => s.restA), segmentsB = handles.segments.flatMap((s) => s.restB);
  const run = (opts, vertices = mesh.vertices, triangles = null, p = points, a = segmentsA, b = segmentsB) => {
    const session = mls.createSession({ vertices, triangles, points: p, segmentsA: a, segmentsB: b, ...opts });
    try {
      return rate(session, seconds);
    } finally {
      session.delete();
    }
  };
  const big = cloud(100000, 10);
  const out = {
    vertices: mesh.vertices.length / 3,
    handles: handles.points.length + handles.segments.length,
    rigidMls: run({ transform: 'rigid' }),
    rigidMlsScalar: run({ transform: 'rigid', scalar: true }),
    mlsArap2: run({ transform: 'rigid', arapIterations: 2 }, mesh.vertices, mesh.triangles),
    cloud100k: run({ transform: 'rigid' }, big.vertices, null, big.points, [], []),
  };
  out.simdOverScalar = out.rigidMls / out.rigidMlsScalar;
  return out;
}
