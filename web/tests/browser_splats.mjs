// The page's splat scenes in headless Debian Chromium (harness.mjs), for the native build's ctest label `web`
// (tests/web.cmake, through run_browser_test.sh). One check per run:
//   node web/tests/browser_splats.mjs SITE pose DIR        a synthetic scene (splat_scene.js) opened by URL, three
//                                                          handles placed on splats and moved: DIR/scene.ply, the
//                                                          page's DIR/page.ply, DIR/page.spz, DIR/handles.json and
//                                                          DIR/spz_decoded.ply (page.spz read back by the library),
//                                                          DIR/page_{similarity,affine}.ply (the other transforms)
//                                                          for run_browser_test.sh to hold against the program
//   node web/tests/browser_splats.mjs SITE formats DIR     the posed scene (DIR/page.ply) as the program writes it in
//                                                          compressed PLY and SPZ version 4 (DIR/program.*), and as
//                                                          a .splat file written here, opened by URL
//   node web/tests/browser_splats.mjs SITE screenshot PNG  a posed scene is drawn by Spark (not blank)
//   node web/tests/browser_splats.mjs SITE hostile         bad splat files opened, NaN targets, far handles, export
//                                                          without splats: a message each, the scene kept
//   node web/tests/browser_splats.mjs SITE bench           web/src/bench_splats.js, as JSON
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { litShare, startPage } from './harness.mjs';
import { splatScenePly } from '../src/splat_scene.js';
import { compareSplatPly, comparePacked, readSplatPly } from './splat_compare.mjs';
import { checkFormats } from './splat_formats.mjs';

const [siteArg, check, arg] = process.argv.slice(2);
const { page, open, extra, fail, finish } = await startPage(siteArg);

/** Opens the scene, puts handles on splats 0, n/2 and n-1, and bends the bar: its bottom end swung sideways. */
async function pose(n, degree) {
  extra.set('/scene.ply', splatScenePly(n, degree));
  await open('?mesh=scene.ply');
  return page.evaluate((n) => {
    const p = window.mlsdeformPage;
    if (p.splatCount() !== n) throw new Error(`the page shows ${p.splatCount()} splats, not ${n}`);
    p.addSplatHandle(Math.floor(n / 2));
    p.addSplatHandle(n - 1);
    const t = p.state.handles.points.map((h) => h.target);
    p.moveHandle(2, [t[2][0] + 3, t[2][1] - 1.2, t[2][2] + 0.5]);
    p.moveHandle(1, [t[1][0] + 0.4, t[1][1] - 0.1, t[1][2] + 0.2]);
    return p.handleCount();
  }, n);
}

/**
 * A click on splat i's centre (as the camera shows it) adds a handle on a splat there; dragging the gizmo 30
 * pixels to the right moves the handle and poses the scene.
 */
async function clickAndDrag(i) {
  const at = await page.evaluate((i) => {
    const p = window.mlsdeformPage, c = p.state.splats.centres;
    p.camera.updateMatrixWorld();
    const v = p.camera.position.clone().set(c[3 * i], c[3 * i + 1], c[3 * i + 2]).project(p.camera);
    return { x: (v.x + 1) * 400, y: (1 - v.y) * 300, count: p.handleCount() };
  }, i);
  await page.mouse.click(at.x, at.y);
  const added = await page.evaluate(() => {
    const p = window.mlsdeformPage, h = p.state.handles.points.at(-1);
    return { count: p.handleCount(), vertex: h.vertex, target: [...h.target], centres: Array.from(p.state.splats.centres) };
  });
  console.log(`a click at (${at.x.toFixed(0)}, ${at.y.toFixed(0)}) on splat ${i} added a handle on splat ${added.vertex}`);
  if (added.count !== at.count + 1 || !(added.vertex >= 0)) fail('a click on a splat did not add a handle on a splat');
  await new Promise((r) => setTimeout(r, 200));
  await page.mouse.move(at.x, at.y);
  await page.mouse.down();
  await page.mouse.move(at.x + 15, at.y, { steps: 4 });
  await page.mouse.move(at.x + 30, at.y, { steps: 4 });
  await page.mouse.up();
  const dragged = await page.evaluate((before) => {
    const p = window.mlsdeformPage, t = p.state.handles.points.at(-1).target, c = p.state.splats.centres;
    let moved = 0;
    for (let k = 0; k < c.length; ++k) moved = Math.max(moved, Math.abs(c[k] - before.centres[k]));
    return { moved, by: Math.hypot(...t.map((x, k) => x - before.target[k])) };
  }, added);
  console.log(`dragging it 30 pixels moved it by ${dragged.by.toFixed(3)} and the splats by up to ${dragged.moved.toFixed(3)}`);
  if (!(dragged.by > 0.05 && dragged.moved > 0.05)) fail('dragging the new handle did not pose the scene');
  // A shift-drag from one splat to another: a segment handle between them, by their indices.
  const ends = await page.evaluate((ks) => {
    const p = window.mlsdeformPage, c = p.state.splats.centres;
    return ks.map((k) => {
      const v = p.camera.position.clone().set(c[3 * k], c[3 * k + 1], c[3 * k + 2]).project(p.camera);
      return { x: (v.x + 1) * 400, y: (1 - v.y) * 300 };
    });
  }, [Math.floor(i / 2), Math.floor((3 * i) / 2)]);
  await page.keyboard.down('Shift');
  await page.mouse.move(ends[0].x, ends[0].y);
  await page.mouse.down();
  await page.mouse.move(ends[1].x, ends[1].y, { steps: 5 });
  await page.mouse.up();
  await page.keyboard.up('Shift');
  const segment = await page.evaluate(() => window.mlsdeformPage.state.handles.segments.at(-1)?.vertices ?? null);
  console.log(`a shift-drag from splat ${Math.floor(i / 2)} to splat ${Math.floor((3 * i) / 2)} made a segment handle on splats ${segment}`);
  if (!segment || !(segment[0] >= 0 && segment[1] >= 0)) fail('a shift-drag between splats did not make a segment handle on splats');
}

/** Opens `bytes` as the file `name` through the page's file input; resolves to the message shown. */
async function drop(name, bytes) {
  extra.set('/' + name, bytes);
  return page.evaluate(async (name) => {
    document.getElementById('error').textContent = '';
    const data = new Uint8Array(await (await fetch('/' + name)).arrayBuffer());
    const input = document.getElementById('file');
    const dt = new DataTransfer();
    dt.items.add(new File([data], name));
    input.files = dt.files;
    input.dispatchEvent(new Event('change'));
    const start = performance.now();
    while (document.getElementById('error').textContent === '' && performance.now() - start < 10000)
      await new Promise((r) => setTimeout(r, 20));
    return document.getElementById('error').textContent;
  }, name);
}

const bytesOf = (b64) => Buffer.from(b64, 'base64');

/** In the page: Spark's unpackSplat of each splat of its mesh, and the SH fields as its shaders extract them. */
async function unpack() {
  const { unpackSplat } = await import('@sparkjsdev/spark');
  const packed = window.mlsdeformPage.state.object.packedSplats, e = packed.splatEncoding;
  const field = (words, bits, i) => {
    const start = i * bits, w = Math.floor(start / 32), o = start % 32;
    let v = words[w] >>> o;
    if (o + bits > 32) v |= words[w + 1] << (32 - o);
    return (v << (32 - bits)) >> (32 - bits);  // sign-extended, as int(x << a) >> b in GLSL
  };
  const bands = [[packed.extra.sh1, 7, 9, 2], [packed.extra.sh2, 8, 15, 4], [packed.extra.sh3, 6, 21, 4]];
  const splats = [];
  for (let i = 0; i < packed.numSplats; ++i) {
    const u = unpackSplat(packed.packedArray, i, e);
    splats.push({
      center: u.center.toArray(), scales: u.scales.toArray(), quaternion: u.quaternion.toArray(), opacity: u.opacity,
      color: [u.color.r, u.color.g, u.color.b],
      sh: bands.map(([a, bits, n, words]) => a && Array.from({ length: n }, (_, j) => field(a.subarray(words * i), bits, j))),
    });
  }
  return { encoding: e, splats };
}

try {
  if (check === 'pose') {
    const n = 2000;
    const handles = await pose(n, 3);
    console.log(`scene of ${n} splats (SH degree 3), ${handles} handles placed on splats and moved`);
    await clickAndDrag(Math.floor(n / 4));
    writeFileSync(join(arg, 'scene.ply'), extra.get('/scene.ply'));
    writeFileSync(join(arg, 'handles.json'), await page.evaluate(() => window.mlsdeformPage.exportHandles()));
    const ply = bytesOf(await page.evaluate(() => window.mlsdeformPage.exportSplats('ply')));
    const spz = bytesOf(await page.evaluate(() => window.mlsdeformPage.exportSplats('spz')));
    writeFileSync(join(arg, 'page.ply'), ply);
    writeFileSync(join(arg, 'page.spz'), spz);
    // What Spark draws: its own decoding of the arrays the module packed, against the posed splats.
    const packed = comparePacked(ply, await page.evaluate(unpack));
    console.log(`Spark's reading of the packed splats against page.ply: ${packed.report}`);
    if (!packed.ok) fail('the splats handed to Spark are not the posed splats within its quantisation');
    console.log(`exported page.ply (${ply.length} bytes) and page.spz (${spz.length} bytes, gzip: ${spz[0] === 0x1f && spz[1] === 0x8b})`);
    // page.spz read back by the library (the page's reader: the browser removes the gzip layer) and written as PLY.
    extra.set('/page.spz', spz);
    const decoded = await page.evaluate(async () => {
      const p = window.mlsdeformPage;
      const r = await fetch('/page.spz');
      const stream = r.body.pipeThrough(new DecompressionStream('gzip'));
      const s = p.state.mls.readSplats(new Uint8Array(await new Response(stream).arrayBuffer()), 'page.spz');
      try {
        s.setup({ points: Array.from(s.rest.subarray(0, 3)) });
        s.deform();  // one handle at rest: every splat's frame is the identity, its bits kept
        let b = '';
        const bytes = s.exportFile('ply', 'decoded.ply');
        for (let i = 0; i < bytes.length; i += 0x8000) b += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
        return btoa(b);
      } finally {
        s.delete();
      }
    });
    writeFileSync(join(arg, 'spz_decoded.ply'), bytesOf(decoded));
    // The same handles under the similarity and the affine transforms (the switch, as a user changes it).
    for (const transform of ['similarity', 'affine']) {
      const b64 = await page.evaluate(async (t) => {
        const select = document.getElementById('transform');
        select.value = t;
        select.dispatchEvent(new Event('change'));
        const shown = document.getElementById('error').textContent;
        if (shown) throw new Error(shown);
        return window.mlsdeformPage.exportSplats('ply');
      }, transform);
      writeFileSync(join(arg, `page_${transform}.ply`), bytesOf(b64));
    }
    const r = compareSplatPly(ply, bytesOf(decoded), 'spz');
    console.log(`page.spz read back against page.ply: ${r.report}`);
    if (!r.ok) fail('the SPZ export is not the PLY export within SPZ\'s bounds');
  } else if (check === 'formats') {
    await checkFormats({ page, open, extra, fail, dir: arg, readSplatPly });
  } else if (check === 'screenshot') {
    await pose(15000, 3);
    // Spark sorts in a worker: the splats appear a few frames later (software WebGL: up to seconds).
    const drawn = () => litShare(page);
    const start = Date.now();
    let share = await drawn();
    while (share <= 0.05 && Date.now() - start < 20000) {
      await new Promise((r) => setTimeout(r, 500));
      share = await drawn();
      if (process.env.MLSDEFORM_WEB_DEBUG) console.error(`${Date.now() - start} ms: ${share}`);
    }
    await new Promise((r) => setTimeout(r, 1000));  // the last sort's frame
    share = await drawn();
    writeFileSync(arg, await page.screenshot({ type: 'png' }));
    console.log(`screenshot ${arg}: ${(100 * share).toFixed(1)}% of the canvas shows splats`);
    if (!(share > 0.05)) fail('the canvas is blank');
  } else if (check === 'hostile') {
    await import('./splat_hostile.mjs').then((m) => m.hostile({ page, pose, drop, fail, extra }));
  } else if (check === 'bench') {
    await open('');
    const fig = await page.evaluate((s) => window.mlsdeformPage.benchmarkSplats({ seconds: s }), Number(arg ?? 3));
    console.log(JSON.stringify(fig, null, 1));
  } else {
    fail(`unknown check '${check}'`);
  }
} catch (e) {
  fail(e.stack ?? String(e));
}
await finish();
