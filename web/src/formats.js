// The page's outputs: the posed mesh (OBJ, binary PLY) and the program's handles file (docs/cli.md, "Handles
// file"), written in JavaScript. The page reads its inputs with the program's own readers, compiled into the
// module (mlsdeform.js: readMesh, readHandles).

/** An error about an input file the module never saw (a failed download, corrupt gzip): "FILE: PROBLEM". */
export class InputError extends Error {
  constructor(file, problem, where = '') {
    super(`${file}: ${where ? where + ': ' : ''}${problem}`);
    this.name = 'InputError';
  }
}

/** The shortest decimal text that reads back to the float x (as the program writes coordinates). */
export function floatText(x) {
  for (let p = 1; p < 10; ++p) {
    const s = x.toPrecision(p);
    if (Math.fround(Number(s)) === x) return String(Number(s));
  }
  return String(x);
}

/** OBJ text of the mesh with the vertices xyz. */
export function encodeObj(mesh, xyz) {
  const out = [];
  for (let i = 0; i < xyz.length; i += 3) out.push(`v ${floatText(xyz[i])} ${floatText(xyz[i + 1])} ${floatText(xyz[i + 2])}`);
  for (const f of mesh.faces) out.push('f ' + f.map((i) => i + 1).join(' '));
  return out.join('\n') + '\n';
}

/** Binary little-endian PLY of the mesh with the vertices xyz (float x, y, z; polygons as the file had them). */
export function encodePly(mesh, xyz) {
  const n = xyz.length / 3;
  const header = `ply\nformat binary_little_endian 1.0\ncomment written by the mlsdeform page\nelement vertex ${n}\n` +
    'property float x\nproperty float y\nproperty float z\n' +
    `element face ${mesh.faces.length}\nproperty list uchar int vertex_indices\nend_header\n`;
  const head = new TextEncoder().encode(header);
  const faceBytes = mesh.faces.reduce((sum, f) => sum + 1 + 4 * f.length, 0);
  const out = new Uint8Array(head.length + 12 * n + faceBytes);
  out.set(head);
  const view = new DataView(out.buffer);
  let at = head.length;
  for (let i = 0; i < 3 * n; ++i, at += 4) view.setFloat32(at, xyz[i], true);
  for (const f of mesh.faces) {
    if (f.length > 255) throw new Error(`a face of ${f.length} corners does not fit PLY's uchar count`);
    view.setUint8(at++, f.length);
    for (const i of f) view.setInt32(at, i, true), (at += 4);
  }
  return out;
}

/** The handles as the program's JSON: the rest by vertex where there is one, the current targets. */
export function encodeHandles(points, segments, region = []) {
  const r = (a) => Array.from(a, (x) => floatText(Math.fround(x))).map(Number);
  return JSON.stringify({
    comment: 'written by the mlsdeform page (docs/web.md): `mlsdeform deform MESH THIS -o OUT` deforms the same way',
    points: points.map((p) => ({ ...(p.vertex >= 0 ? { vertex: p.vertex } : { rest: r(p.rest) }), target: r(p.target), ...(p.name ? { name: p.name } : {}) })),
    segments: segments.map((s) => ({ ...(s.vertices ? { vertices: s.vertices } : { rest: [r(s.restA), r(s.restB)] }), target: [r(s.targetA), r(s.targetB)] })),
    ...(region.length ? { region } : {}),
  }, null, 1) + '\n';
}
