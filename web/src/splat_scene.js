// A synthetic Gaussian splat scene as a 3DGS PLY file (docs/splats.md, "The layout"): the page's splat benchmark
// and the browser tests (web/tests/browser_splats.mjs) make their scenes here, the same in the browser and in
// Node. A bar of n splats along y, coloured in bands along it, each with random SH bands, opacity, scales and
// orientation.

/** The PLY bytes of n splats of SH degree `degree` (0..3), from a fixed seed. */
export function splatScenePly(n, degree, seed = 1) {
  let s = seed >>> 0 || 1;
  const next = () => ((s = (Math.imul(s, 1103515245) + 12345) >>> 0) / 2 ** 32);
  const k = 3 * ((degree + 1) * (degree + 1) - 1);
  const names = ['x', 'y', 'z', 'nx', 'ny', 'nz', 'f_dc_0', 'f_dc_1', 'f_dc_2'];
  for (let j = 0; j < k; ++j) names.push(`f_rest_${j}`);
  names.push('opacity', 'scale_0', 'scale_1', 'scale_2', 'rot_0', 'rot_1', 'rot_2', 'rot_3');
  const header = `ply\nformat binary_little_endian 1.0\nelement vertex ${n}\n` +
    names.map((p) => `property float ${p}\n`).join('') + 'end_header\n';
  const head = new TextEncoder().encode(header);
  const out = new Uint8Array(head.length + 4 * names.length * n);
  out.set(head);
  const view = new DataView(out.buffer);
  let at = head.length;
  const put = (x) => {
    view.setFloat32(at, x, true);
    at += 4;
  };
  const side = Math.max(1, Math.round(Math.cbrt(n / 8)));
  for (let i = 0; i < n; ++i) {
    // A bar 1 x 8 x 1 (3DGS's y points down), jittered lattice.
    put((next() + (i % side)) / side - 0.5);
    put(8 * ((next() + Math.floor(i / (side * side))) / Math.ceil(n / (side * side))) - 4);
    put((next() + (Math.floor(i / side) % side)) / side - 0.5);
    put(0), put(0), put(0);
    // Band 0: bands of colour along the bar, a little noise (the picture of docs/web.md compresses well).
    const y = view.getFloat32(at - 20, true), x = view.getFloat32(at - 24, true);
    put(1.1 * Math.sin(1.3 * y) + 0.1 * next());
    put(1.1 * Math.cos(0.9 * y + 1) + 0.1 * next());
    put(0.8 * x + 0.3 * Math.sin(2 * y) + 0.1 * next());
    for (let j = 0; j < k; ++j) put(0.5 * (next() - 0.5));
    put(4 * next() - 1);
    for (let c = 0; c < 3; ++c) put(Math.log(0.02 + 0.06 * next()));
    for (let c = 0; c < 4; ++c) put(next() - 0.5 || 0.1);
  }
  return out;
}
