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

export interface Mlsdeform {
  /** Throws an Error with the library's message on invalid input (TypeError / RangeError for the wrapper's checks). */
  createSession(options: SessionOptions): Session;
  /** Reads OBJ, OFF or PLY (by the name's extension; a ".gz" name with its decompressed bytes) with the
   * program's strict reader; throws an Error with the program's message ("NAME: line N: PROBLEM"). */
  readMesh(data: Uint8Array | ArrayBuffer | string, name: string): MeshFile;
  /** Reads a handles file against the mesh's vertices as `mlsdeform deform` does; throws the program's message. */
  readHandles(text: Uint8Array | string, name: string, vertices: ArrayLike<number>): HandlesFile;
  /** The emscripten module. */
  module: unknown;
}

export function loadMlsdeform(options?: { factory?: (moduleOptions: object) => Promise<unknown>; moduleOptions?: object }): Promise<Mlsdeform>;
