// Two 3DGS PLY files of the same splats (binary little-endian floats, as the program and the page write them)
// compared property by property, for the browser tests (browser_splats.mjs). With 'spz', each within the
// quantisation bound of SPZ as the program writes it (docs/splats.md, "Error each quantisation allows"): centre
// 2^-13 per axis, log scale 1/32, alpha 1/510, band 0 1/76.5, SH coefficients 1/256, orientation 0.0048 rad;
// each bound widened by float's rounding of the decoded value (a few eps of its size: 1e-6 relative).

/** The vertex element's float properties by name, and the count. */
export function readSplatPly(bytes) {
  const buf = Buffer.from(bytes);
  const end = buf.indexOf('end_header\n');
  if (end < 0) throw new Error('no PLY header');
  const header = buf.subarray(0, end).toString('latin1').split('\n');
  if (!header.includes('format binary_little_endian 1.0')) throw new Error('not binary little-endian');
  const names = [];
  let count = -1;
  for (const line of header) {
    const w = line.split(' ');
    if (w[0] === 'element' && w[1] === 'vertex') count = Number(w[2]);
    else if (w[0] === 'element') throw new Error(`an element other than vertex: ${w[1]}`);
    else if (w[0] === 'property') {
      if (w[1] !== 'float') throw new Error(`property ${w[2]} is ${w[1]}, not float`);
      names.push(w[2]);
    }
  }
  const body = buf.subarray(end + 'end_header\n'.length);
  if (body.length !== 4 * names.length * count) throw new Error(`${body.length} bytes of data for ${count} splats`);
  const props = {};
  names.forEach((name, k) => {
    const a = new Float32Array(count);
    for (let i = 0; i < count; ++i) a[i] = body.readFloatLE(4 * (i * names.length + k));
    props[name] = a;
  });
  return { count, props };
}

const sigmoid = (x) => 1 / (1 + Math.exp(-x));

/** Each splat of `b` against `a` within format's bounds ('spz'); {ok, report} with the largest error of each. */
export function compareSplatPly(aBytes, bBytes, format) {
  if (format !== 'spz') throw new Error(`no bounds for ${format}`);
  const a = readSplatPly(aBytes), b = readSplatPly(bBytes);
  if (a.count !== b.count) return { ok: false, report: `${a.count} splats against ${b.count}` };
  const rel = 1e-6;
  const worst = {}, bound = {};
  const check = (what, err, limit) => {
    worst[what] = Math.max(worst[what] ?? 0, err / limit);
    bound[what] = limit;
  };
  const P = (s, name) => s.props[name];
  const rest = Object.keys(a.props).filter((k) => k.startsWith('f_rest_'));
  for (let i = 0; i < a.count; ++i) {
    for (const c of ['x', 'y', 'z']) check('centre', Math.abs(P(a, c)[i] - P(b, c)[i]), 2 ** -13 + rel * Math.abs(P(a, c)[i]));
    for (const c of [0, 1, 2]) {
      check('log scale', Math.abs(P(a, `scale_${c}`)[i] - P(b, `scale_${c}`)[i]), 1 / 32 + rel * 10);
      check('band 0', Math.abs(P(a, `f_dc_${c}`)[i] - P(b, `f_dc_${c}`)[i]), 1 / 76.5 + rel * 4);
    }
    check('alpha', Math.abs(sigmoid(P(a, 'opacity')[i]) - sigmoid(P(b, 'opacity')[i])), 1 / 510 + rel);
    for (const k of rest) check('SH', Math.abs(P(a, k)[i] - P(b, k)[i]), 1 / 256 + rel);
    const qa = [0, 1, 2, 3].map((c) => P(a, `rot_${c}`)[i]), qb = [0, 1, 2, 3].map((c) => P(b, `rot_${c}`)[i]);
    const na = Math.hypot(...qa), nb = Math.hypot(...qb);
    const dot = Math.min(1, Math.abs(qa.reduce((s, x, c) => s + x * qb[c], 0)) / (na * nb));
    check('orientation', 2 * Math.acos(dot), 0.0048 + 1e-5);
  }
  const ok = Object.values(worst).every((w) => w <= 1);
  const report = Object.keys(worst).map((k) => `${k} ${(worst[k] * bound[k]).toExponential(2)} / ${bound[k].toExponential(2)}`).join(', ');
  return { ok, report };
}
