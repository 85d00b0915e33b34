// Types of web/src/mlsdeform.js (docs/web.md).

export interface SessionOptions {
  /** Rest vertices, xyz interleaved. */
  vertices: ArrayLike<number>;
  /** Vertex index triples; needed for arapIterations > 0. */
  triangles?: ArrayLike<number> | null;
  /** Point handles' rest positions, xyz interleaved. */
  points?: ArrayLike<number> | null;
  /** Segment handles' rest end points (as many as segmentsB), xyz interleaved. */
  segmentsA?: ArrayLike<number> | null;
  segmentsB?: ArrayLike<number> | null;
  transform?: 'rigid' | 'similarity' | 'affine';
  /** The paper's u in w = |p - v|^-u (>= 1; default 2). */
  weightExponent?: number;
  centroids?: 'mls' | 'rbf';
  /** Surface-ARAP iterations after MLS (needs triangles); default 0. */
  arapIterations?: number;
  /** Run the scalar reference instead of the WebAssembly SIMD kernels. */
  scalar?: boolean;
  /** The vertices that may move (the library's Options::region); default all. Not with arapIterations > 0. */
  region?: ArrayLike<number> | null;
}

/** A mesh as the program's reader reads it. */
export interface MeshFile {
  /** Vertices, xyz, in the file's order. */
  vertices: Float32Array;
  /** The polygons' fan triangles, vertex index triples. */
  triangles: Uint32Array;
  /** The polygons as the file has them. */
  faces: number[][];
}

/** A handles file resolved against a mesh: rest positions and the first frame's targets, floats. */
export interface HandlesFile {
  points: { rest: number[]; target: number[]; vertex: number }[];
  segments: { restA: number[]; restB: number[]; targetA: number[]; targetB: number[]; vertices: [number, number] | null }[];
  groups: { points: number[]; segments: number[] }[];
  region: number[];
}

export interface Session {
  readonly vertexCount: number;
  readonly pointCount: number;
  readonly segmentCount: number;
  /** Targets, xyz: the points, then the segments' first ends, then their second ends; a view on the module's memory. */
  readonly targets: Float32Array;
  /** The deformed vertices, xyz; a view on the module's memory, rewritten by deform(). */
  readonly output: Float32Array;
  /** Deforms with the current targets; throws an Error with the library's message. Allocates nothing. */
  deform(): Float32Array;
  /** Frees the session's memory in the module; the session is unusable afterwards. */
  delete(): void;
}

/** A Gaussian splat scene read by the files library (readSplats; docs/splats.md, docs/web.md "Splat scenes"). */
export interface SplatScene {
  readonly count: number;
  readonly shDegree: number;
  /** Spark's texture rows: the packed arrays' length in splats (a multiple of 2048). */
  readonly capacity: number;
  /** Spark's SplatEncoding for the packed arrays (the ranges chosen for the scene). */
  readonly encoding: { rgbMin: number; rgbMax: number; lnScaleMin: number; lnScaleMax: number; sh1Max: number; sh2Max: number; sh3Max: number };
  /** The centres as read, xyz (a copy). */
  readonly rest: Float32Array;
  /** Views on the module's memory, valid after views() (deform() calls it): the posed centres, the targets
   * (points, then segments' first ends, then their second ends), Spark's packed splats (4 words each). */
  readonly centres: Float32Array;
  readonly targets: Float32Array;
  readonly packed: Uint32Array;
  /** Remakes the views when the module's memory grew; true when they changed. */
  views(): boolean;
  /** Band 1, 2 or 3 of the SH in Spark's layout (2, 4, 4 words a splat), or null. */
  sh(band: 1 | 2 | 3): Uint32Array | null;
  /** Places handles at rest (xyz lists); throws the library's message. */
  setup(options: { points?: ArrayLike<number>; segmentsA?: ArrayLike<number>; segmentsB?: ArrayLike<number>;
    transform?: 'rigid' | 'similarity' | 'affine'; weightExponent?: number; centroids?: 'mls' | 'rbf' }): void;
  /** Poses the scene as `mlsdeform deform` does and packs it; true when the views were remade. */
  deform(): boolean;
  /** The posed scene as the program writes it: 'ply' (3DGS) or 'spz' (version 3 before its gzip layer). */
  exportFile(format: 'ply' | 'spz', name: string): Uint8Array;
  delete(): void;
}

export interface Mlsdeform {
  /** Throws an Error with the library's message on invalid input (TypeError / RangeError for the wrapper's checks). */
  createSession(options: SessionOptions): Session;
  /** Reads OBJ, OFF or PLY (by the name's extension; a ".gz" name with its decompressed bytes) with the
   * program's strict reader; throws an Error with the program's message ("NAME: line N: PROBLEM"). */
  readMesh(data: Uint8Array | ArrayBuffer | string, name: string): MeshFile;
  /** Reads a handles file against the mesh's vertices as `mlsdeform deform` does; throws the program's message. */
  readHandles(text: Uint8Array | string, name: string, vertices: ArrayLike<number>): HandlesFile;
  /** Reads a splat file (3DGS PLY, compressed PLY, SPZ without its gzip layer, .splat) as the program does;
   * throws the program's message ("NAME: not a Gaussian splat file ..." for a PLY mesh). */
  readSplats(data: Uint8Array | ArrayBuffer | string, name: string): SplatScene;
  /** The batched rotation fit (fit_rotations_interleaved, float): n row-major 3 x 3 matrices one after the other
   * (9 n values); returns `out` (or a new array) with the rotation fit to each; throws the library's message. */
  fitRotations(H: ArrayLike<number>, out?: Float32Array | null): Float32Array;
  /** The emscripten module. */
  module: unknown;
}

export function loadMlsdeform(options?: { factory?: (moduleOptions: object) => Promise<unknown>; moduleOptions?: object }): Promise<Mlsdeform>;
