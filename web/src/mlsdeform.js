// mlsdeform in JavaScript: the library's WebAssembly module (build-web/web/mlsdeform_wasm.mjs, the C API of
// web/src/api_session.cpp) as an ES module. Vertices go in once and come out through Float32Array views on
// the module's memory: a frame copies nothing and allocates nothing (docs/web.md).
//
//   import { loadMlsdeform } from './mlsdeform.js';
//   const mls = await loadMlsdeform();
//   const s = mls.createSession({ vertices, triangles, points, transform: 'rigid' });
//   s.targets.set(moved); s.deform(); use(s.output); s.delete();

const TRANSFORMS = { rigid: 0, similarity: 1, affine: 2 };
const CENTROIDS = { mls: 0, rbf: 1 };

export async function loadMlsdeform(options = {}) {
  const moduleOptions = { ...(options.moduleOptions ?? {}) };
  if (typeof process === 'object' && process.versions?.node) {
    // emscripten 3.1.6's ES module still reads CommonJS globals under Node and takes the .wasm's file: URL for
    // a path: give it the globals and the path.
    const { createRequire } = await import('node:module');
    const { dirname, join } = await import('node:path');
    const { fileURLToPath } = await import('node:url');
    const here = dirname(fileURLToPath(import.meta.url));
    globalThis.require ??= createRequire(import.meta.url);
    globalThis.__dirname ??= here;
    moduleOptions.locateFile ??= (file) => join(here, file);
  }
  const factory = options.factory ?? (await import('./mlsdeform_wasm.mjs')).default;
  const M = await factory(moduleOptions);
  const fail = () => {
    throw new Error(M.UTF8ToString(M._mls_last_error()));
  };
  // Copies a typed array into a fresh block of the module's memory; the caller frees it.
  const copyIn = (array, Type) => {
    if (!array || array.length === 0) return 0;
    const ptr = M._malloc(array.length * Type.BYTES_PER_ELEMENT);
    if (!ptr) throw new Error('out of memory');
    new Type(M.HEAPU8.buffer, ptr, array.length).set(array);
    return ptr;
  };

  class Session {
    constructor(opts) {
      const { vertices, triangles = null, points = null, segmentsA = null, segmentsB = null, region = null } = opts;
      const transform = TRANSFORMS[opts.transform ?? 'rigid'];
      const centroids = CENTROIDS[opts.centroids ?? 'mls'];
      if (transform === undefined) throw new TypeError(`transform must be one of ${Object.keys(TRANSFORMS)}`);
      if (centroids === undefined) throw new TypeError(`centroids must be one of ${Object.keys(CENTROIDS)}`);
      for (const [name, a] of [['vertices', vertices], ['points', points], ['segmentsA', segmentsA], ['segmentsB', segmentsB]])
        if (a !== null && a.length % 3 !== 0) throw new RangeError(`${name}: length ${a.length} is not a multiple of 3`);
      if (triangles !== null && triangles.length % 3 !== 0)
        throw new RangeError(`triangles: length ${triangles.length} is not a multiple of 3`);
      if ((segmentsA?.length ?? 0) !== (segmentsB?.length ?? 0))
        throw new RangeError('segmentsA and segmentsB must have the same length');
      const ptrs = [
        copyIn(Float32Array.from(vertices), Float32Array),
        copyIn(triangles && Int32Array.from(triangles), Int32Array),
        copyIn(points && Float32Array.from(points), Float32Array),
        copyIn(segmentsA && Float32Array.from(segmentsA), Float32Array),
        copyIn(segmentsB && Float32Array.from(segmentsB), Float32Array),
        copyIn(region && Int32Array.from(region), Int32Array),
      ];
      try {
        this._s = M._mls_session_create(ptrs[0], vertices.length / 3, ptrs[1], (triangles?.length ?? 0) / 3,
          ptrs[2], (points?.length ?? 0) / 3, ptrs[3], ptrs[4], (segmentsA?.length ?? 0) / 3, transform,
          opts.weightExponent ?? 2, centroids, opts.arapIterations ?? 0, opts.scalar ? 0 : -1, ptrs[5],
          region?.length ?? 0);
      } finally {
        for (const p of ptrs) if (p) M._free(p);
      }
      if (!this._s) fail();
      this.vertexCount = M._mls_session_vertex_count(this._s);
      this.pointCount = M._mls_session_point_count(this._s);
      this.segmentCount = M._mls_session_segment_count(this._s);
      this._views();
    }
    // The views are remade only when the module's memory grew (which detaches the old buffer).
    _views() {
      const buffer = M.HEAPF32.buffer;
      if (this._buffer === buffer) return;
      this._buffer = buffer;
      const k = this.pointCount, s = this.segmentCount;
      this._targets = new Float32Array(buffer, M._mls_session_targets(this._s), 3 * (k + 2 * s));
      this._output = new Float32Array(buffer, M._mls_session_output(this._s), 3 * this.vertexCount);
    }
    _alive() {
      if (!this._s) throw new Error('mlsdeform: the session was deleted');
    }
    /** The handles' targets, xyz: the point handles, then the segments' first ends, then their second ends. */
    get targets() {
      this._alive();
      this._views();
      return this._targets;
    }
    /** The deformed vertices, xyz, written by deform(). */
    get output() {
      this._alive();
      this._views();
      return this._output;
    }
    /** Deforms with the current targets into output; throws an Error with the library's message. */
    deform() {
      this._alive();
      if (M._mls_session_deform(this._s) !== 0) fail();
      return this.output;
    }
    delete() {
      if (this._s) M._mls_session_delete(this._s);
      this._s = 0;
      this._targets = this._output = this._buffer = null;
    }
  }

  // Bytes (a string is taken as UTF-8) and a NUL-terminated name in the module's memory, for the readers.
  const bytesIn = (data) => {
    const bytes = typeof data === 'string' ? new TextEncoder().encode(data) : data instanceof Uint8Array ? data : new Uint8Array(data);
    const ptr = M._malloc(Math.max(bytes.length, 1));
    if (!ptr) throw new Error('out of memory');
    M.HEAPU8.set(bytes, ptr);
    return [ptr, bytes.length];
  };
  const nameIn = (name) => bytesIn(new TextEncoder().encode(`${name}\0`))[0];
  const u32 = (ptr, n) => new Uint32Array(M.HEAPU8.buffer, ptr, n).slice();

  /**
   * Reads a mesh with the program's strict reader (OBJ, OFF, PLY ASCII or binary; the format by the name's
   * extension, through a ".gz": hand over the decompressed bytes). Throws an Error with the program's message.
   */
  function readMesh(data, name) {
    const [ptr, size] = bytesIn(data);
    const namePtr = nameIn(name);
    let m = 0;
    try {
      m = M._mls_mesh_read(ptr, size, namePtr);
    } finally {
      M._free(ptr);
      M._free(namePtr);
    }
    if (!m) fail();
    try {
      const n = M._mls_mesh_vertex_count(m);
      const vertices = new Float32Array(M.HEAPU8.buffer, M._mls_mesh_vertices(m), 3 * n).slice();
      const triangles = u32(M._mls_mesh_triangles(m), 3 * M._mls_mesh_triangle_count(m));
      const start = u32(M._mls_mesh_face_start(m), M._mls_mesh_face_count(m) + 1);
      const corners = u32(M._mls_mesh_face_indices(m), M._mls_mesh_face_index_count(m));
      const faces = [];
      for (let f = 0; f + 1 < start.length; ++f) faces.push(Array.from(corners.subarray(start[f], start[f + 1])));
      return { vertices, triangles, faces };
    } finally {
      M._mls_mesh_delete(m);
    }
  }

  /**
   * Reads a handles file (the program's JSON) against a mesh's vertices, as `mlsdeform deform` does: the rest
   * positions and the first frame's targets (groups' motions applied). Throws an Error with the program's message.
   */
  function readHandles(text, name, vertices) {
    const [ptr, size] = bytesIn(text);
    const namePtr = nameIn(name);
    const v = copyIn(Float32Array.from(vertices), Float32Array);
    let json = 0;
    try {
      json = M._mls_handles_read(ptr, size, namePtr, v, vertices.length / 3);
    } finally {
      for (const p of [ptr, namePtr, v]) if (p) M._free(p);
    }
    if (!json) fail();
    return JSON.parse(M.UTF8ToString(json));
  }

  /**
   * The batched rotation fit (fit_rotations_interleaved): `H` holds n 3 x 3 matrices row-major one after the
   * other (9 n values, numpy's (n, 3, 3) layout); returns `out` (a new Float32Array of the same length if not
   * given) holding the rotation fit to each, as the native library computes it in float. Throws an Error with
   * the library's message (a non-finite entry, named as H[i, r, c]).
   */
  function fitRotations(H, out = null) {
    if (H.length % 9 !== 0) throw new RangeError(`H: length ${H.length} is not a multiple of 9`);
    const result = out ?? new Float32Array(H.length);
    if (result.length !== H.length) throw new RangeError(`out: length ${result.length}, expected ${H.length}`);
    const ptr = copyIn(Float32Array.from(H), Float32Array);
    try {
      if (ptr && M._mls_fit_rotations(ptr, ptr, H.length / 9) !== 0) fail();
      if (ptr) result.set(new Float32Array(M.HEAPU8.buffer, ptr, H.length));
    } finally {
      if (ptr) M._free(ptr);
    }
    return result;
  }

  /**
   * A Gaussian splat scene (docs/splats.md) read by the program's readers: a 3DGS PLY, a compressed PLY, an SPZ
   * file given without its gzip layer, or a .splat file (the format by the name, or a PLY's header). `setup()`
   * places handles on it; `deform()` moves the centres and turns each splat and its SH bands by its centre's frame
   * as `mlsdeform deform` does, and packs them for Spark (`packed`, `sh(band)`: views on the module's memory,
   * remade by `views()` when it grew); `exportFile(format, name)` gives the bytes the program writes.
   */
  class SplatScene {
    constructor(data, name) {
      const [ptr, size] = bytesIn(data);
      const namePtr = nameIn(name);
      try {
        this._s = M._mls_splats_read(ptr, size, namePtr);
      } finally {
        M._free(ptr);
        M._free(namePtr);
      }
      if (!this._s) fail();
      this.count = M._mls_splats_count(this._s);
      this.shDegree = M._mls_splats_sh_degree(this._s);
      this.capacity = M._mls_splats_capacity(this._s);
      const e = (i) => M._mls_splats_encoding(this._s, i);
      this.encoding = { rgbMin: e(0), rgbMax: e(1), lnScaleMin: e(2), lnScaleMax: e(3), sh1Max: e(4), sh2Max: e(5), sh3Max: e(6) };
      this.rest = new Float32Array(M.HEAPU8.buffer, M._mls_splats_rest(this._s), 3 * this.count).slice();
      this.pointCount = this.segmentCount = 0;
    }
    /** Views on the module's memory, remade when it grew: returns true when they changed. */
    views() {
      const buffer = M.HEAPU8.buffer;
      if (this._buffer === buffer) return false;
      this._buffer = buffer;
      const s = this._s, u32 = (ptr, n) => (ptr ? new Uint32Array(buffer, ptr, n) : null);
      this.packed = u32(M._mls_splats_packed(s), 4 * this.capacity);
      this._sh = [null, u32(M._mls_splats_sh(s, 1), 2 * this.capacity), u32(M._mls_splats_sh(s, 2), 4 * this.capacity),
        u32(M._mls_splats_sh(s, 3), 4 * this.capacity)];
      this.centres = new Float32Array(buffer, M._mls_splats_centres(s), 3 * this.count);
      const k = this.pointCount, m = this.segmentCount;
      this.targets = k + m ? new Float32Array(buffer, M._mls_splats_targets(s), 3 * (k + 2 * m)) : new Float32Array(0);
      return true;
    }
    /** Band 1, 2 or 3's packed SH (null where the scene's degree lacks it). */
    sh(band) {
      this.views();
      return this._sh[band];
    }
    /** Handles at rest (xyz lists as createSession's) and the switches; throws the library's message. */
    setup({ points = [], segmentsA = [], segmentsB = [], transform = 'rigid', weightExponent = 2, centroids = 'mls' }) {
      const t = TRANSFORMS[transform], c = CENTROIDS[centroids];
      if (t === undefined || c === undefined) throw new TypeError('transform or centroids unknown');
      const ptrs = [points, segmentsA, segmentsB].map((a) => copyIn(a.length ? Float32Array.from(a) : null, Float32Array));
      let status;
      try {
        status = M._mls_splats_setup(this._s, ptrs[0], points.length / 3, ptrs[1], ptrs[2], segmentsA.length / 3, t,
          weightExponent, c);
      } finally {
        for (const p of ptrs) if (p) M._free(p);
      }
      if (status !== 0) fail();
      this.pointCount = points.length / 3;
      this.segmentCount = segmentsA.length / 3;
      this._buffer = null;
      this.views();
    }
    /** Deforms with `targets` (write them first); throws the library's message, keeping the last pose. */
    deform() {
      this.views();
      if (M._mls_splats_deform(this._s) !== 0) fail();
      return this.views();
    }
    /** The posed scene's file: 'ply' (3DGS, the program's bytes) or 'spz' (version 3 before its gzip layer). */
    exportFile(format, name) {
      const namePtr = nameIn(name);
      let status;
      try {
        status = M._mls_splats_export(this._s, format === 'spz' ? 1 : 0, namePtr);
      } finally {
        M._free(namePtr);
      }
      if (status !== 0) fail();
      return new Uint8Array(M.HEAPU8.buffer, M._mls_splats_bytes(this._s), M._mls_splats_bytes_size(this._s)).slice();
    }
    delete() {
      if (this._s) M._mls_splats_delete(this._s);
      this._s = 0;
    }
  }

  return {
    createSession: (opts) => new Session(opts),
    readSplats: (data, name) => new SplatScene(data, name),
    fitRotations,
    readMesh,
    readHandles,
    module: M,
  };
}
