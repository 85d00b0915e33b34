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
  /** The emscripten module. */
  module: unknown;
}

export function loadMlsdeform(options?: { factory?: (moduleOptions: object) => Promise<unknown>; moduleOptions?: object }): Promise<Mlsdeform>;
