// The page's splat scenes (docs/web.md, "Splat scenes"): a Gaussian splat file (3DGS PLY, compressed PLY, SPZ,
// .splat) read, deformed and written by the module (the files library: mlsdeform.js SplatScene), drawn by Spark
// (splat_view.js). page.js hands over its view and state as `ctx`; the handles are the page's (interaction.js),
// placed on splat centres.
import * as THREE from 'three';
import { SplatView, boundsOf } from './splat_view.js';
import { InputError } from './formats.js';

/** Names the files library reads as splat files whatever their header says (a .ply is asked of the library). */
export const splatName = (name) => /\.(spz|splat)$/i.test(name) || /\.compressed\.ply$/i.test(name);

/** SPZ versions 2 and 3 are gzip streams: the browser's gzip removes that layer (the module has no zlib). */
export async function ungzip(bytes, name) {
  if (!(bytes.length >= 2 && bytes[0] === 0x1f && bytes[1] === 0x8b)) return bytes;
  try {
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
    return new Uint8Array(await new Response(stream).arrayBuffer());
  } catch (e) {
    throw new InputError(name, `corrupt gzip data (${e.message})`);
  }
}

/** The browser's gzip of `bytes` (an SPZ file from the payload the module writes). */
export async function gzip(bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new CompressionStream('gzip'));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

export function installSplats(ctx) {
  const { state, scene, camera, renderer, orbit } = ctx;
  const view = new SplatView(renderer, scene);
  const up = new THREE.Vector3(0, 1, 0);

  /** 3DGS files are right-down-forward: the camera's up is -y for them (OrbitControls keeps its own copy). */
  function setUp(y) {
    camera.up.set(0, y, 0);
    orbit._quat.setFromUnitVectors(camera.up, up);
    orbit._quatInverse.copy(orbit._quat).invert();
  }

  /**
   * The splat scene in `bytes`, or null when the library reads it as no splat file (a .ply mesh: the caller
   * opens it as a mesh). Throws the library's message for a splat file it refuses.
   */
  async function read(bytes, name) {
    const data = /\.spz$/i.test(name) ? await ungzip(bytes, name) : bytes;
    let splats;
    try {
      splats = state.mls.readSplats(data, name);
    } catch (e) {
      if (!splatName(name) && / not a Gaussian splat file /.test(e.message)) return null;
      throw e;
    }
    try {
      await view.load();
    } catch (e) {
      splats.delete();
      throw new Error(`the splat renderer did not load (${e.message})`);
    }
    return splats;
  }

  /** Shows the scene with its handles (or one at the first splat); all or nothing. */
  function open(splats, handles, name) {
    if (splats.count === 0) throw new InputError(name, 'no splats to show');
    const previous = { ...state };
    const mesh = { vertices: splats.rest, triangles: new Uint32Array(0), faces: [] };
    const sphere = boundsOf(splats.rest);
    Object.assign(state, { splats, mesh, handles, selected: -1, group: [], radius: sphere.radius });
    try {
      rebuild();
    } catch (e) {
      Object.assign(state, previous);
      throw e;
    }
    if (previous.splats && previous.splats !== splats) previous.splats.delete();
    previous.session?.delete();  // the mesh's deformer, if a mesh was open
    state.session = null;
    if (previous.object) scene.remove(previous.object);
    state.object = view.show(splats);
    scene.add(state.object);
    setUp(-1);
    const c = sphere.center;
    orbit.target.copy(c);
    camera.position.set(c.x, c.y, c.z - 3.2 * state.radius);
    camera.near = state.radius / 100;
    camera.far = state.radius * 100;
    camera.updateProjectionMatrix();
    state.splatName = name;
    return status();
  }

  /** The status line: the scene and its handles now. */
  function status() {
    const { splats, handles } = state;
    return `${state.splatName}: ${splats.count} splats, SH degree ${splats.shDegree}; ${handles.points.length} point ` +
      `and ${handles.segments.length} segment handles`;
  }

  /** Back to a mesh: the splat scene `splats` (no longer the page's) freed. */
  function close(splats) {
    view.dispose();
    splats.delete();
    setUp(1);
  }

  /** The handles at rest, the switches: a new deformer over the centres (as the program builds one). */
  function rebuild() {
    const { handles } = state;
    const o = ctx.options();
    if (o.arapIterations > 0)
      throw new Error('ARAP iterations need a surface, and a splat scene has no faces (set them to 0)');
    state.splats.setup({
      points: handles.points.flatMap((p) => p.rest),
      segmentsA: handles.segments.flatMap((s) => s.restA),
      segmentsB: handles.segments.flatMap((s) => s.restB),
      transform: o.transform,
      weightExponent: o.weightExponent,
      centroids: o.centroids,
    });
    document.getElementById('status').textContent = status();
    deform();
  }

  /** The targets into the module, the scene deformed (positions, splats, SH) and handed to Spark. */
  function deform() {
    const { splats, handles } = state;
    const k = handles.points.length, s = handles.segments.length;
    splats.views();
    const t = splats.targets;
    handles.points.forEach((p, i) => t.set(p.target, 3 * i));
    handles.segments.forEach((g, i) => {
      t.set(g.targetA, 3 * (k + i));
      t.set(g.targetB, 3 * (k + s + i));
    });
    const t0 = performance.now();
    splats.deform();
    if (view.mesh && view.splats === splats) view.update();
    ctx.timed(performance.now() - t0);
    ctx.placeMarkers();
    for (const m of state.markers) {  // drawn after Spark's splats and over them: a handle sits inside its splat
      m.material.depthTest = false;
      m.material.transparent = true;
      m.renderOrder = 1e6;
    }
  }

  /** The splat whose centre the ray passes nearest (within 1% of the scene's radius), as a surface hit. */
  function pick(raycaster) {
    const i = view.pick(raycaster.ray, 0.01 * state.radius);
    if (i < 0) return null;
    return { point: new THREE.Vector3().fromArray(state.splats.centres, 3 * i), splat: i };
  }

  /** The posed scene as a file: 'ply' (the program's bytes) or 'spz' (gzip by the browser: version 3). */
  async function exportFile(format) {
    if (!state.splats) throw new Error('no splat scene is open: open a splat file (.ply, .spz, .splat) first');
    const name = format === 'spz' ? 'posed.spz' : 'posed.ply';
    const bytes = state.splats.exportFile(format, name);
    return format === 'spz' ? gzip(bytes) : bytes;
  }

  return { read, open, close, rebuild, deform, pick, exportFile, view };
}
