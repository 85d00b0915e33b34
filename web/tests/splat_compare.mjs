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

/**
 * What Spark reads of the page's splats (its own unpackSplat, and band 1-3 fields decoded as its shaders decode
 * them, `unpacked` from browser_splats.mjs) against the posed splats of the page's PLY, within Spark's
 * quantisation (spark_pack.hpp): a centre's half keeps 10 bits (truncated: 2^-10 of its size), a log scale
 * 21 / 254 per step, alpha and a colour byte 1 / 255 of their range, an SH field max / 63, 127 or 31 (each
 * rounded: half a step). The rotation: its angle in a byte over [0, pi] (within pi / 510 = 0.0062 rad); its axis
 * as octahedral bytes, each within 1/255 of the folded (x, y) / (|x| + |y| + |z|), which moves the octahedron's
 * point by at most sqrt(1 + 1 + 2^2) / 255 = 0.0096 (z = 1 - |x| - |y| moves by both), and normalising a point of
 * norm >= 1/sqrt(3) turns it by at most sqrt(3) times that: 0.0166 rad; a rotation about an axis turned by d
 * differs by at most 2 d: 0.0062 + 0.0333 = 0.0395 rad.
 */
export function comparePacked(plyBytes, unpacked) {
  const { count, props } = readSplatPly(plyBytes);
  const e = unpacked.encoding;
  const C0 = 0.28209479177387814;
  const worst = {};
  const check = (what, err, limit) => (worst[what] = Math.max(worst[what] ?? 0, err / limit));
  const k = Object.keys(props).filter((p) => p.startsWith('f_rest_')).length / 3;
  for (let i = 0; i < count; ++i) {
    const u = unpacked.splats[i];
    ['x', 'y', 'z'].forEach((c, j) => check('centre', Math.abs(u.center[j] - props[c][i]), Math.abs(props[c][i]) * 2 ** -10 + 1e-7));
    for (let j = 0; j < 3; ++j) check('log scale', Math.abs(Math.log(u.scales[j]) - props[`scale_${j}`][i]), 21 / 254 / 2 + 1e-6);
    check('alpha', Math.abs(u.opacity - sigmoid(props.opacity[i])), 1 / 510 + 1e-7);
    for (let j = 0; j < 3; ++j) {
      const rgb = Math.min(e.rgbMax, Math.max(e.rgbMin, 0.5 + C0 * props[`f_dc_${j}`][i]));
      check('colour', Math.abs(u.color[j] - rgb), (e.rgbMax - e.rgbMin) / 510 + 1e-6);
    }
    const q = [0, 1, 2, 3].map((c) => props[`rot_${c}`][i]), n = Math.hypot(...q);
    const dot = Math.abs(q[0] * u.quaternion[3] + q[1] * u.quaternion[0] + q[2] * u.quaternion[1] + q[3] * u.quaternion[2]) / n;
    check('rotation', 2 * Math.acos(Math.min(1, dot)), 0.0395 + 1e-4);
    // Band l's coefficient j of channel c: Spark's field 3 j + c, 3DGS's f_rest_(c k + first + j).
    [[1, 0, 3, 63, e.sh1Max], [2, 3, 5, 127, e.sh2Max], [3, 8, 7, 31, e.sh3Max]].forEach(([l, first, m, steps, max]) => {
      if (!u.sh[l - 1]) return;
      for (let j = 0; j < m; ++j)
        for (let c = 0; c < 3; ++c)
          check(`SH band ${l}`, Math.abs((u.sh[l - 1][3 * j + c] * max) / steps - props[`f_rest_${c * k + first + j}`][i]), max / steps / 2 + 1e-6);
    });
  }
  const ok = Object.values(worst).every((w) => w <= 1);
  return { ok, report: Object.keys(worst).map((w) => `${w} ${worst[w].toFixed(2)} of its bound`).join(', ') };
}
