// Hostile input to the page's splat scenes (browser_splats.mjs hostile): each bad file opened through the file
// input shows a message naming it, and the scene that was open stays, still posable; targets that are not
// finite are refused with a message; handles far outside the scene still pose it; exporting splats with a
// mesh open says why it cannot.
import { splatScenePly } from '../src/splat_scene.js';

export async function hostile({ page, pose, drop, fail }) {
  const n = 1000;
  await pose(n, 1);
  const good = splatScenePly(64, 1);
  const header = Buffer.from(good).toString('latin1').split('end_header\n')[0] + 'end_header\n';
  const cases = [
    // name, bytes, what the message must say
    ['truncated.ply', good.subarray(0, good.length - 100), /truncated.ply/],
    ['huge.ply', Buffer.concat([Buffer.from(header.replace('element vertex 64', 'element vertex 4000000000'), 'latin1'),
      Buffer.from(good.subarray(header.length, header.length + 4096))]), /huge.ply/],
    ['magic.spz', Buffer.from('this is not an SPZ file at all, only text'), /magic.spz/],
    // SPZ version 2's header (as its payload: the page hands it over without a gzip layer) promising 2^31 splats.
    ['huge.spz', Buffer.from([0x4e, 0x47, 0x53, 0x50, 2, 0, 0, 0, 0, 0, 0, 0x80, 0, 12, 0, 0, 1, 2, 3, 4]), /huge.spz/],
    ['corrupt.spz', Buffer.from([0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3, 1, 2, 3, 4, 5, 6]), /corrupt.spz: corrupt gzip data/],
    ['odd.splat', new Uint8Array(33), /odd.splat/],
    ['empty.spz', new Uint8Array(0), /empty.spz/],
    ['nan.ply', (() => {
      const b = Buffer.from(good);
      b.writeFloatLE(NaN, header.length);  // splat 0's x
      return b;
    })(), /nan.ply/],
  ];
  for (const [name, bytes, expect] of cases) {
    const t0 = Date.now();
    const shown = await drop(name, bytes);
    const after = await page.evaluate(() => {
      const p = window.mlsdeformPage, t = p.state.handles.points[1].target;
      p.moveHandle(1, [t[0], t[1], t[2] + 0.01]);
      return p.splatCount();
    });
    console.log(`${name}: "${shown}" (${Date.now() - t0} ms); the scene of ${after} splats still poses`);
    if (!expect.test(shown)) fail(`${name}: the message does not say what is wrong: "${shown}"`);
    if (after !== n) fail(`${name}: the page shows ${after} splats, not the scene's ${n}`);
  }
  // A target that is not finite: refused with a message, the pose kept; the handle set back poses again.
  const nan = await page.evaluate(() => {
    const p = window.mlsdeformPage, t = [...p.state.handles.points[1].target];
    let message = '';
    try {
      p.moveHandle(1, [NaN, t[1], t[2]]);
    } catch (e) {
      message = e.message;
    }
    p.moveHandle(1, t);
    return message;
  });
  console.log(`a NaN target: "${nan}"`);
  if (!/not finite/.test(nan)) fail('a NaN target was not refused with a message');
  // Handles far outside the scene: the pose follows them, the export works.
  const far = await page.evaluate(async () => {
    const p = window.mlsdeformPage;
    p.moveHandle(2, [1e4, -1e4, 1e4]);
    const c = p.state.splats.centres;
    return { x: Math.max(...c.subarray(0, 3 * 10)), bytes: (await p.exportSplats('ply')).length };
  });
  console.log(`a handle 10^4 away: the splats follow (x up to ${far.x.toFixed(1)}), PLY export ${far.bytes} base64 characters`);
  if (!(far.bytes > 0)) fail('the export failed with a far handle');
  // Beyond SPZ's range (|x| < 2048): the export is refused, naming the splat and the property.
  const spz = await page.evaluate(async () => {
    try {
      await window.mlsdeformPage.exportSplats('spz');
      return '';
    } catch (e) {
      return e.message;
    }
  });
  console.log(`SPZ export with splats beyond its range: "${spz}"`);
  if (!/splat \d+/.test(spz)) fail('an SPZ export out of range was not refused naming the splat');
  // A mesh open: exporting splats says there are none.
  const mesh = await page.evaluate(async () => {
    const p = window.mlsdeformPage;
    await p.openUrl('human_man.obj');
    try {
      await p.exportSplats('spz');
      return '';
    } catch (e) {
      return e.message;
    }
  });
  console.log(`export SPZ with the human open: "${mesh}"`);
  if (!/no splat scene/.test(mesh)) fail('exporting splats without a scene did not say so');
}
