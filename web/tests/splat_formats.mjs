// The page opens the splat formats the program writes (browser_splats.mjs formats DIR): the posed scene
// DIR/page.ply, as `mlsdeform deform` writes it in compressed PLY (DIR/program.compressed.ply) and SPZ
// (DIR/program.spz: version 4 where the program has zstd, which the page refuses, saying so; version 3
// otherwise), and as a `.splat` file written here from page.ply (antimatter15's layout: 32 bytes a splat). The
// centres the page reads: a .splat's exactly page.ply's (floats), a compressed PLY's within its chunk's
// quantisation (docs/splats.md: (max - min) / 2046 at most per axis), an SPZ's within 2^-13.
import { readFileSync } from 'node:fs';
import { join } from 'node:path';

/** antimatter15's .splat of the splats: centre, linear scales, RGBA bytes, quaternion bytes (w x y z). */
function splatFile({ count, props: p }) {
  const out = Buffer.alloc(32 * count);
  const C0 = 0.28209479177387814, byte = (x) => Math.max(0, Math.min(255, Math.round(x)));
  for (let i = 0; i < count; ++i) {
    const at = 32 * i;
    ['x', 'y', 'z'].forEach((c, j) => out.writeFloatLE(p[c][i], at + 4 * j));
    for (let j = 0; j < 3; ++j) out.writeFloatLE(Math.exp(p[`scale_${j}`][i]), at + 12 + 4 * j);
    for (let j = 0; j < 3; ++j) out[at + 24 + j] = byte(255 * (0.5 + C0 * p[`f_dc_${j}`][i]));
    out[at + 27] = byte(255 / (1 + Math.exp(-p.opacity[i])));
    const q = [0, 1, 2, 3].map((j) => p[`rot_${j}`][i]), n = Math.hypot(...q);
    for (let j = 0; j < 4; ++j) out[at + 28 + j] = byte(128 * (q[j] / n) + 128);
  }
  return out;
}

export async function checkFormats({ page, open, extra, fail, dir, readSplatPly }) {
  const ply = readSplatPly(readFileSync(join(dir, 'page.ply')));
  const n = ply.count;
  const files = { 'scene.splat': splatFile(ply), 'program.compressed.ply': readFileSync(join(dir, 'program.compressed.ply')),
    'program.spz': readFileSync(join(dir, 'program.spz')) };
  await open('');
  for (const [name, bytes] of Object.entries(files)) {
    extra.set('/' + name, bytes);
    const r = await page.evaluate(async (name) => {
      const p = window.mlsdeformPage;
      try {
        await p.openUrl(name);
      } catch (e) {
        return { error: e.message };
      }
      return { count: p.splatCount(), rest: Array.from(p.state.splats.rest) };
    }, name);
    if (r.error) {
      const v4 = bytes.subarray(0, 4).toString('latin1') === 'NGSP';
      console.log(`${name}: refused: ${r.error}`);
      if (!(v4 && /zstd/.test(r.error))) fail(`${name}: the page refused it: ${r.error}`);
      continue;
    }
    if (r.count !== n) fail(`${name}: ${r.count} splats, not ${n}`);
    let worst = 0, bound = 0;
    for (let i = 0; i < n; ++i) {
      const chunk = Math.floor(i / 256) * 256;
      for (const [j, c] of ['x', 'y', 'z'].entries()) {
        let b = 0;
        if (name.endsWith('.spz')) b = 2 ** -13 + 1e-6 * Math.abs(ply.props[c][i]);
        if (name.endsWith('.compressed.ply')) {
          const a = ply.props[c].subarray(chunk, Math.min(n, chunk + 256));
          b = (Math.max(...a) - Math.min(...a)) / 2046 + 1e-6;
        }
        const e = Math.abs(r.rest[3 * i + j] - ply.props[c][i]);
        if (e > b) fail(`${name}: splat ${i}'s ${c} is ${r.rest[3 * i + j]}, page.ply's ${ply.props[c][i]} (bound ${b})`);
        if (b > 0) worst = Math.max(worst, e / b);
        bound = Math.max(bound, b);
      }
    }
    console.log(`${name}: ${r.count} splats, centres within ${worst.toFixed(2)} of their bound (largest bound ${bound.toExponential(2)})`);
  }
}
