// WebAssembly against native on one workload: the 24 frames of data/human_bend.json on the human, rigid MLS,
// deformed in a loop by the module under Node (the SSE4.2 twins in WebAssembly SIMD, one thread), for
// comparison with `MLSDEFORM_ISA=sse4_2 build/tools/mlsdeform deform -j 1 -m data/human_man.obj
// -H data/human_bend.json -o /tmp/f.obj`, which prints its time per frame (docs/web.md, "Figures").
//   node --no-experimental-fetch web/tests/bench_frames.mjs build-web/site [seconds]
import { readFileSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { pathToFileURL } from 'node:url';

const site = resolve(process.argv[2]);
const seconds = Number(process.argv[3] ?? 3);
const { loadMlsdeform } = await import(pathToFileURL(join(site, 'mlsdeform.js')));
const mls = await loadMlsdeform();
const mesh = mls.readMesh(readFileSync(join(site, 'human_man.obj')), 'human_man.obj');
const text = readFileSync(join(site, 'human_bend.json'), 'utf8');
const handles = mls.readHandles(text, 'human_bend.json', mesh.vertices);
const frames = JSON.parse(text).frames;
const s = mls.createSession({
  vertices: mesh.vertices,
  points: handles.points.flatMap((p) => p.rest),
  segmentsA: handles.segments.flatMap((g) => g.restA),
  segmentsB: handles.segments.flatMap((g) => g.restB),
});
// Each frame's targets, as the program resolves them: the frame's position, or the handle's own target.
const k = handles.points.length;
const targets = frames.map((f) => {
  const t = Float32Array.from(s.targets);
  f.points.forEach((p, i) => p && t.set(p.map(Math.fround), 3 * i));
  handles.segments.forEach((g, i) => (t.set(g.targetA, 3 * (k + i)), t.set(g.targetB, 3 * (k + handles.segments.length + i))));
  return t;
});
let count = 0;
const start = performance.now();
let best = Infinity;
while (performance.now() - start < 1000 * seconds) {
  const t0 = performance.now();
  for (const t of targets) {
    s.targets.set(t);
    s.deform();
  }
  best = Math.min(best, (performance.now() - t0) / targets.length);
  count += targets.length;
}
const mean = (performance.now() - start) / count;
console.log(`${count} frames: ${mean.toFixed(3)} ms per frame (best pass ${best.toFixed(3)} ms), ${(1000 / mean).toFixed(0)} frames/s`);
s.delete();
