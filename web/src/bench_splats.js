// The page's splat benchmark (docs/web.md, "Figures"): poses per second of a synthetic scene of 10^5 splats
// (splat_scene.js), each pose the module's deformation (centres, each splat turned, its SH bands rotated: the
// program's code) and the upload to Spark (the arrays copied into Spark's, its textures uploaded to WebGL),
// without drawing. Run by web/tests/browser_splats.mjs bench in headless Chromium, or from the console:
// await mlsdeformPage.benchmarkSplats().
import { SplatView } from './splat_view.js';
import { splatScenePly } from './splat_scene.js';

/** Poses per second over at least `seconds`, and the mean milliseconds of each part. */
function rate(splats, view, gl, seconds) {
  const t = splats.targets;
  const x0 = t[0];
  const pose = (i) => {
    t[0] = x0 + 0.05 * Math.sin(i);
    const a = performance.now();
    splats.deform();
    const b = performance.now();
    view.update();
    view.uploadNow();
    gl.finish();  // the upload done, not queued
    return [b - a, performance.now() - b];
  };
  pose(0);  // warm: the textures' first upload allocates them
  let frames = 0, deformMs = 0, uploadMs = 0;
  const start = performance.now();
  while (performance.now() - start < 1000 * seconds) {
    const [d, u] = pose(++frames);
    deformMs += d;
    uploadMs += u;
  }
  const elapsed = performance.now() - start;
  t[0] = x0;
  return { perSecond: (1000 * frames) / elapsed, deformMs: deformMs / frames, uploadMs: uploadMs / frames, frames };
}

export async function benchmarkSplats(mls, renderer, { seconds = 3, n = 100000, degrees = [3, 0], handles = 10 } = {}) {
  const out = { splats: n, handles };
  const gl = renderer.getContext();
  for (const degree of degrees) {
    const splats = mls.readSplats(splatScenePly(n, degree), `bench_sh${degree}.ply`);
    const view = new SplatView(renderer, null);
    try {
      await view.load();
      const points = [];
      for (let i = 0; i < handles; ++i) {
        const j = Math.floor((i * n) / handles);
        points.push(...splats.rest.subarray(3 * j, 3 * j + 3));
      }
      splats.setup({ points, transform: 'rigid' });
      view.show(splats);
      view.packed.ensureShTextures();  // made by Spark's first draw otherwise
      out[`sh${degree}`] = rate(splats, view, gl, seconds);
    } finally {
      view.dispose();
      splats.delete();
    }
  }
  return out;
}
