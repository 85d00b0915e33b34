// The page's files: OBJ meshes and the program's handles file (docs/cli.md, "Handles file"), read and written
// in JavaScript. The program's C++ readers cannot be compiled in yet (docs/web.md, "Limits"); these follow their
// rules for what the page reads: every `v` line kept in order (vertex i of a handles file is the i-th `v`),
// polygons fanned into triangles, and every malformed line refused with the file, the line and the problem.

/** An error about an input file: "FILE: line N: PROBLEM", as the program words it. */
export class InputError extends Error {
  constructor(file, problem, where = '') {
    super(`${file}: ${where ? where + ': ' : ''}${problem}`);
    this.name = 'InputError';
  }
}

const NUMBER = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;

function number(token, file, where) {
  if (token === undefined) throw new InputError(file, 'missing number', where);
  if (!NUMBER.test(token)) throw new InputError(file, `'${token}' is not a number`, where);
  const v = Math.fround(Number(token));
  if (!Number.isFinite(v)) throw new InputError(file, `${token} is not finite in float`, where);
  return v;
}

/** Parses OBJ text: { vertices: Float32Array (xyz), triangles: Uint32Array, faces: [[i, j, k, ...]] }. */
export function parseObj(text, file) {
  const v = [];
  const faces = [];
  const lines = text.split('\n');
  for (let n = 0; n < lines.length; ++n) {
    const line = lines[n].replace(/#.*/, '').trim();
    if (line === '') continue;
    const t = line.split(/\s+/);
    const where = `line ${n + 1}`;
    if (t[0] === 'v') {
      if (t.length < 4 || t.length > 5) throw new InputError(file, 'a vertex needs x y z (and an optional w)', where);
      v.push(number(t[1], file, where), number(t[2], file, where), number(t[3], file, where));
    } else if (t[0] === 'f') {
      if (t.length < 4) throw new InputError(file, 'face with fewer than three corners', where);
      faces.push(t.slice(1).map((c) => {
        const s = c.split('/')[0];
        if (!/^[+-]?\d+$/.test(s)) throw new InputError(file, `'${c}' is not a vertex index`, where);
        let i = Number(s);
        const count = v.length / 3;
        i = i < 0 ? count + i : i - 1;
        if (i < 0 || i >= count) throw new InputError(file, `vertex index ${s} out of range (${count} vertices so far)`, where);
        return i;
      }));
    } else if (!['vn', 'vt', 'vp', 'o', 'g', 's', 'usemtl', 'mtllib', 'l', 'p'].includes(t[0])) {
      throw new InputError(file, `unknown statement '${t[0]}'`, where);
    }
  }
  if (v.length === 0) throw new InputError(file, 'no vertices');
  const tri = [];
  for (const f of faces) for (let k = 1; k + 1 < f.length; ++k) tri.push(f[0], f[k], f[k + 1]);
  return { vertices: Float32Array.from(v), triangles: Uint32Array.from(tri), faces };
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

function vec3(x, file, where) {
  if (!Array.isArray(x) || x.length !== 3 || !x.every((c) => typeof c === 'number' && Number.isFinite(c)))
    throw new InputError(file, 'expected [x, y, z]', where);
  return x;
}

function index(x, count, file, where) {
  if (!Number.isInteger(x) || x < 0) throw new InputError(file, 'expected a vertex index (an integer >= 0)', where);
  if (x >= count) throw new InputError(file, `vertex ${x} out of range (the mesh has ${count})`, where);
  return x;
}

const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];

/**
 * Parses a handles file against a mesh: { points: [{rest, target, vertex, name}], segments: [{restA, restB,
 * targetA, targetB, vertices, name}] }, targets those of the first frame. Computed in double, rounded to float.
 */
export function parseHandles(text, file, mesh) {
  let json;
  try {
    json = JSON.parse(text.replace(/^\s*\/\/.*$/gm, ''));
  } catch (e) {
    throw new InputError(file, `not JSON (${e.message})`);
  }
  if (typeof json !== 'object' || json === null || Array.isArray(json)) throw new InputError(file, 'expected an object');
  for (const k of Object.keys(json))
    if (!['comment', 'points', 'segments', 'frames', 'groups', 'region'].includes(k)) throw new InputError(file, `unknown key '${k}'`, '/' + k);
  for (const k of ['groups', 'region'])
    if (json[k] !== undefined) throw new InputError(file, `"${k}" is not supported by the page yet (the program reads it)`, '/' + k);
  const count = mesh.vertices.length / 3;
  const at = (i) => [mesh.vertices[3 * i], mesh.vertices[3 * i + 1], mesh.vertices[3 * i + 2]];
  const points = (json.points ?? []).map((p, i) => {
    const w = `/points/${i}`;
    const vertex = p.vertex !== undefined ? index(p.vertex, count, file, w + '/vertex') : -1;
    const rest = vertex >= 0 ? at(vertex) : vec3(p.rest, file, w + '/rest');
    let target = rest;
    if (p.target !== undefined) target = vec3(p.target, file, w + '/target');
    if (p.offset !== undefined) target = add(rest, vec3(p.offset, file, w + '/offset'));
    return { rest, target, vertex, name: p.name ?? '' };
  });
  const segments = (json.segments ?? []).map((s, i) => {
    const w = `/segments/${i}`;
    const vertices = s.vertices !== undefined ? s.vertices.map((x, k) => index(x, count, file, `${w}/vertices/${k}`)) : null;
    const [restA, restB] = vertices ? vertices.map(at) : [vec3(s.rest?.[0], file, w + '/rest/0'), vec3(s.rest?.[1], file, w + '/rest/1')];
    let [targetA, targetB] = [restA, restB];
    if (s.target !== undefined) [targetA, targetB] = [vec3(s.target[0], file, w + '/target/0'), vec3(s.target[1], file, w + '/target/1')];
    if (s.offset !== undefined) {
      const d = vec3(s.offset, file, w + '/offset');
      [targetA, targetB] = [add(restA, d), add(restB, d)];
    }
    return { restA, restB, targetA, targetB, vertices, name: s.name ?? '' };
  });
  if (points.length + segments.length === 0) throw new InputError(file, 'no handles');
  const frame = json.frames?.[0];
  if (frame) {
    const entry = (e, rest, w) => (Array.isArray(e) ? vec3(e, file, w) : e.target !== undefined ? vec3(e.target, file, w + '/target') : add(rest, vec3(e.offset, file, w + '/offset')));
    (frame.points ?? []).forEach((e, i) => {
      if (e !== null) points[i].target = entry(e, points[i].rest, `/frames/0/points/${i}`);
    });
    (frame.segments ?? []).forEach((e, i) => {
      if (e === null) return;
      const s = segments[i];
      if (Array.isArray(e) && Array.isArray(e[0])) [s.targetA, s.targetB] = [vec3(e[0], file, `/frames/0/segments/${i}/0`), vec3(e[1], file, `/frames/0/segments/${i}/1`)];
      else if (e.offset !== undefined) {
        const d = vec3(e.offset, file, `/frames/0/segments/${i}/offset`);
        [s.targetA, s.targetB] = [add(s.restA, d), add(s.restB, d)];
      }
    });
  }
  return { points, segments };
}

/** The handles as the program's JSON: the rest by vertex where there is one, the current targets. */
export function encodeHandles(points, segments) {
  const r = (a) => Array.from(a, (x) => floatText(Math.fround(x))).map(Number);
  return JSON.stringify({
    comment: 'written by the mlsdeform page (docs/web.md): `mlsdeform deform MESH THIS -o OUT` deforms the same way',
    points: points.map((p) => ({ ...(p.vertex >= 0 ? { vertex: p.vertex } : { rest: r(p.rest) }), target: r(p.target), ...(p.name ? { name: p.name } : {}) })),
    segments: segments.map((s) => ({ ...(s.vertices ? { vertices: s.vertices } : { rest: [r(s.restA), r(s.restB)] }), target: [r(s.targetA), r(s.targetB)] })),
  }, null, 1) + '\n';
}
