// The page in headless Debian Chromium (puppeteer-core drives /usr/bin/chromium; nothing is downloaded), for
// the native build's ctest label `web` (tests/web.cmake). One check per run:
//   node web/tests/browser.mjs SITE compare CLI_OBJ [exact]  the exported OBJ of the human bending (URL
//                                                     parameters) against `mlsdeform deform`'s first frame,
//                                                     every vertex (the bounds: compare.mjs)
//   node web/tests/browser.mjs SITE interact [DIR]    a click on the surface adds a handle; dragging it deforms;
//                                                     with DIR, the page's OBJ and handles file are written there
//   node web/tests/browser.mjs SITE malformed DIR     DIR/broken.obj opened shows its error, word for word
//                                                     DIR/message.txt (`mlsdeform deform`'s) where there is one;
//                                                     the page still works
//   node web/tests/browser.mjs SITE formats DIR       DIR/human.{obj,off,off.gz,ply} (the program's outputs) opened
//                                                     by URL give the same vertices and faces
//   node web/tests/browser.mjs SITE screenshot PNG    the mesh is drawn (not blank); the screenshot is kept
//   node web/tests/browser.mjs SITE bench             the benchmarks of web/src/bench.js, as JSON
// Exit 77 (skipped) where Chromium is not installed.
import { existsSync, readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { compareObj } from './compare.mjs';
import { litShare, startPage } from './harness.mjs';

const [siteArg, check, arg, arg2] = process.argv.slice(2);
const { site, page, open, extra, errors, fail, finish } = await startPage(siteArg);
try {
  if (check === 'compare') {
    await open('?mesh=human_man.obj&handles=human_bend.json');
    const obj = await page.evaluate(() => window.mlsdeformPage.exportObj());
    const r = compareObj(obj, readFileSync(arg, 'utf8'), readFileSync(join(site, 'human_man.obj'), 'utf8'), arg2 === 'exact');
    console.log(`compared ${r.count} vertices: largest difference ${r.worst.toExponential(3)} (bound ${r.bound.toExponential(3)}) at vertex ${r.at}`);
    if (!(r.worst <= r.bound)) fail('the page and `mlsdeform deform` disagree beyond the bound');
  } else if (check === 'interact') {
    await open('');
    const before = await page.evaluate(() => window.mlsdeformPage.handleCount());
    // The chest, between the handles (the navel is one): where the human's front faces the camera.
    const [x, y] = [400, 190];
    await page.mouse.click(x, y);
    const after = await page.evaluate(() => window.mlsdeformPage.handleCount());
    if (after !== before + 1) fail(`a click on the surface made ${after - before} handles, not 1`);
    // At the clicked point of the surface, not at a vertex: its rest position is no vertex's.
    const atVertex = await page.evaluate(() => {
      const s = window.mlsdeformPage.state, h = s.handles.points[s.handles.points.length - 1], v = s.mesh.vertices;
      let nearest = Infinity;
      for (let i = 0; i < v.length; i += 3) nearest = Math.min(nearest, Math.hypot(v[i] - h.rest[0], v[i + 1] - h.rest[1], v[i + 2] - h.rest[2]));
      return nearest;
    });
    console.log(`the new handle's rest position is ${atVertex.toExponential(2)} from the nearest vertex`);
    if (!(atVertex > 0)) fail('the new handle sits on a vertex, not at the clicked point');
    // Drag the gizmo's centre (the new handle, selected by the click) 40 pixels to the right.
    const start = await page.evaluate(() => {
      const s = window.mlsdeformPage.state;
      return { out: Array.from(s.session.output), target: s.handles.points[s.handles.points.length - 1].target };
    });
    await new Promise((r) => setTimeout(r, 200));
    await page.mouse.move(x, y);
    await page.mouse.down();
    await page.mouse.move(x + 20, y, { steps: 5 });
    await page.mouse.move(x + 40, y, { steps: 5 });
    await page.mouse.up();
    const dragged = await page.evaluate((b) => {
      const s = window.mlsdeformPage.state, t = s.handles.points[s.handles.points.length - 1].target;
      let moved = 0;
      for (let i = 0; i < b.out.length; ++i) moved = Math.max(moved, Math.abs(b.out[i] - s.session.output[i]));
      return { moved, dx: t[0] - b.target[0], dy: t[1] - b.target[1] };
    }, start);
    console.log(`click added handle ${after - 1}; dragging it 40 pixels moved it by (${dragged.dx.toFixed(4)}, ${dragged.dy.toFixed(4)}) and the mesh by up to ${dragged.moved.toFixed(4)}`);
    if (!(dragged.dx > 0.02 && Math.abs(dragged.dy) < dragged.dx / 4)) fail('the drag did not move the handle to the right');
    if (!(dragged.moved > 0.02)) fail('dragging the new handle did not deform the mesh');
    // A shift-drag on the surface draws a segment handle.
    const segments = await page.evaluate(() => window.mlsdeformPage.state.handles.segments.length);
    await page.keyboard.down('Shift');
    await page.mouse.move(380, 330);
    await page.mouse.down();
    await page.mouse.move(380, 380, { steps: 5 });
    await page.mouse.up();
    await page.keyboard.up('Shift');
    const drawn = await page.evaluate(() => window.mlsdeformPage.state.handles.segments.length);
    console.log(`a shift-drag made ${drawn - segments} segment handle(s)`);
    if (drawn !== segments + 1) fail('a shift-drag on the surface did not make one segment handle');
    // Three handles as a group, turned by the gizmo (its events as a drag sends them): they keep their distances.
    const group = await page.evaluate(() => {
      const p = window.mlsdeformPage, s = p.state, members = [3, 4, 5];
      const at = () => members.map((i) => [...s.handles.points[i].target]);
      const distances = (x) => [[0, 1], [1, 2], [0, 2]].map(([a, b]) => Math.hypot(...[0, 1, 2].map((c) => x[a][c] - x[b][c])));
      const before = at();
      p.selectGroup(members);
      p.gizmo.dispatchEvent({ type: 'dragging-changed', value: true });
      p.gizmo.object.rotateZ(0.4);
      p.gizmo.dispatchEvent({ type: 'objectChange' });
      p.gizmo.dispatchEvent({ type: 'dragging-changed', value: false });
      const after = at(), d0 = distances(before), d1 = distances(after);
      return { moved: Math.max(...after.flatMap((x, k) => x.map((v, c) => Math.abs(v - before[k][c])))),
        stretch: Math.max(...d0.map((d, k) => Math.abs(d - d1[k]))) };
    });
    console.log(`turning a group of 3 handles by 0.4 rad moved them by up to ${group.moved.toFixed(4)}, distances kept to ${group.stretch.toExponential(2)}`);
    if (!(group.moved > 0.05)) fail('the group did not move');
    // The turn is computed in double and each target rounded to float once: coordinates below 2 in size move by
    // at most half an ulp (1.2e-7) each, so a distance changes by at most 2 sqrt(3) 1.2e-7 = 4.1e-7.
    if (!(group.stretch <= 4.2e-7)) fail('the group did not move rigidly');
    if (arg) {
      writeFileSync(join(arg, 'page.obj'), await page.evaluate(() => window.mlsdeformPage.exportObj()));
      writeFileSync(join(arg, 'handles.json'), await page.evaluate(() => window.mlsdeformPage.exportHandles()));
    }
  } else if (check === 'malformed') {
    await open('');
    extra.set('/broken.obj', readFileSync(join(arg, 'broken.obj')));
    const expected = existsSync(join(arg, 'message.txt')) ? readFileSync(join(arg, 'message.txt'), 'utf8').trim() : null;
    await page.evaluate(async () => {
      const text = await (await fetch('/broken.obj')).text();
      const input = document.getElementById('file');
      const dt = new DataTransfer();
      dt.items.add(new File([text], 'broken.obj'));
      input.files = dt.files;
      input.dispatchEvent(new Event('change'));
    });
    await page.waitForFunction(() => document.getElementById('error').textContent !== '', { timeout: 10000 });
    const shown = await page.$eval('#error', (e) => e.textContent);
    console.log(`error shown: ${shown}`);
    if (!shown.includes('broken.obj') || !shown.includes('line 3')) fail(`the error does not name the file and line: ${shown}`);
    if (expected !== null) {
      console.log(`mlsdeform deform says: ${expected}`);
      if (shown !== expected) fail('the page and `mlsdeform deform` word the error differently');
    }
    const still = await page.evaluate(() => {
      const p = window.mlsdeformPage;
      p.moveHandle(3, [0.1, 1.5, 0.3]);
      return p.state.mesh.vertices.length / 3;
    });
    if (still !== 6890) fail(`after the error the page shows ${still} vertices, not the human's 6890`);
  } else if (check === 'formats') {
    const read = {};
    for (const f of ['human.obj', 'human.off', 'human.off.gz', 'human.ply']) {
      extra.set('/' + f, readFileSync(join(arg, f)));
      await open(`?mesh=${f}`);
      read[f] = await page.evaluate(() => {
        const m = window.mlsdeformPage.state.mesh;
        return { vertices: Array.from(m.vertices), faces: JSON.stringify(m.faces) };
      });
      console.log(`${f}: ${read[f].vertices.length / 3} vertices, ${JSON.parse(read[f].faces).length} faces`);
    }
    const ref = read['human.obj'];
    if (ref.vertices.length !== 3 * 6890) fail(`human.obj: ${ref.vertices.length / 3} vertices, not 6890`);
    for (const f of ['human.off', 'human.off.gz', 'human.ply']) {
      const differ = read[f].vertices.findIndex((x, i) => !Object.is(x, ref.vertices[i]));
      if (read[f].vertices.length !== ref.vertices.length || differ >= 0) fail(`${f}: vertices differ from the OBJ's (at ${differ})`);
      if (read[f].faces !== ref.faces) fail(`${f}: faces differ from the OBJ's`);
    }
  } else if (check === 'screenshot') {
    await open('?mesh=human_man.obj&handles=human_bend.json');
    await new Promise((r) => setTimeout(r, 500));
    const png = await page.screenshot({ type: 'png' });
    writeFileSync(arg, png);
    // Not blank: the share of pixels that differ from the background colour (#20242a) by more than a little.
    const share = await litShare(page);
    console.log(`screenshot ${arg}: ${(100 * share).toFixed(1)}% of the canvas shows something`);
    if (!(share > 0.02)) fail('the canvas is blank');
  } else if (check === 'bench') {
    await open('');
    const fig = await page.evaluate(() => window.mlsdeformPage.benchmark({ seconds: 2 }));
    const render = await page.evaluate(async () => {
      const p = window.mlsdeformPage, s = p.state, h = s.handles.points[3], t = [...h.target];
      p.renderRate();
      const start = performance.now();
      let k = 0;
      await new Promise((done) => {
        const step = () => {
          p.moveHandle(3, [t[0], t[1] + 0.05 * Math.sin(++k / 10), t[2]]);
          if (performance.now() - start < 3000) requestAnimationFrame(step);
          else done();
        };
        requestAnimationFrame(step);
      });
      return p.renderRate();
    });
    fig.dragWithRendering = render;
    console.log(JSON.stringify(fig, null, 1));
  } else {
    fail(`unknown check '${check}'`);
  }
} catch (e) {
  fail(e.stack ?? String(e));
}
await finish();
