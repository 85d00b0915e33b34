"""Mesh files and handles files in Python, for jobs that run without the `mlsdeform` program (mlsdeform.dask).

    V, faces = files.read_mesh("in.ply.gz")          # float32 (n, 3), Faces
    anim = files.read_handles("h.json", V)           # the program's handles file (docs/cli.md), resolved
    files.write_mesh("out.ply", X, faces)            # all or nothing: a temporary file, then a rename

Formats by file name: `.obj`, `.ply` (ASCII or binary, read; binary little-endian, written), `.gz` of either
(read), and `.npy` (written: the vertices only). Coordinates are read as the program reads them: in the
precision asked for (float32 by default, as its `--precision`), decimal text correctly rounded to it.
The handles file is resolved as the program resolves it (targets in double, rounded once to the session's
precision), so the same file gives bitwise the same handles here and in `mlsdeform deform`.
Bad input raises ValueError naming the file and, for a handles file, the JSON path of the problem.
"""
import gzip
import json
import math
from fractions import Fraction
import os
import re
import uuid

import numpy as np

__all__ = ["Faces", "Animation", "read_mesh", "write_mesh", "read_handles", "write_atomically"]


class Faces:
    """Polygons as `counts` (vertices per face) and `indices` (all faces' vertex indices, in order)."""

    def __init__(self, counts, indices):
        self.counts = np.asarray(counts, dtype=np.int64)
        self.indices = np.asarray(indices, dtype=np.int64)
        if self.counts.sum() != len(self.indices):
            raise ValueError("face counts do not add up to the number of indices")

    def __len__(self):
        return len(self.counts)

    def ply_block(self):
        """The face element of a binary little-endian PLY (a uchar count, then int indices, per face): encoded
        once and kept, since every frame of an animation writes the same faces."""
        block = getattr(self, "_ply", None)
        if block is None:
            block = self._ply = _encode_ply_faces(self)
        return block

    def __getstate__(self):
        return {"counts": self.counts, "indices": self.indices}  # not the encodings: they are remade where used

    def triangles(self):
        """(m, 3) vertex indices, or None unless every face is a triangle."""
        if len(self.counts) and np.all(self.counts == 3):
            return self.indices.reshape(-1, 3)
        return None if len(self.counts) else np.zeros((0, 3), np.int64)


# ---- reading meshes -----------------------------------------------------------------------------------------


def _open(path):
    with open(path, "rb") as f:
        magic = f.read(2)
    return gzip.open(path, "rb") if magic == b"\x1f\x8b" else open(path, "rb")


def read_mesh(path, dtype=np.float32):
    """Reads an OBJ or PLY file (or its .gz): (vertices (n, 3) of `dtype`, Faces)."""
    name = path[:-3] if path.endswith(".gz") else path
    ext = os.path.splitext(name)[1].lower()
    if ext not in (".obj", ".ply"):
        raise ValueError(f"{path}: unknown mesh format (.obj, .ply, and their .gz)")
    try:
        with _open(path) as f:
            data = f.read()
    except OSError as e:
        raise ValueError(f"{path}: cannot read: {e.strerror or e}") from e
    coords, faces = (_read_obj if ext == ".obj" else _read_ply)(data, path)
    V = _decimals(coords, dtype) if coords.dtype.kind in "SU" else coords.astype(dtype)
    if not np.isfinite(V).all():
        raise ValueError(f"{path}: a vertex has a non-finite coordinate")
    if len(faces.indices) and (faces.indices.min() < 0 or faces.indices.max() >= len(V)):
        raise ValueError(f"{path}: a face refers to a vertex out of range (the mesh has {len(V)} vertices)")
    return V, faces


def _read_obj(data, path):
    vertices, counts, indices = [], [], []
    for number, line in enumerate(data.decode("utf-8", "replace").splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            if len(parts) not in (4, 5, 7):
                raise ValueError(f"{path}: line {number}: a vertex needs 3 coordinates (or 4, or 6 with a colour)")
            try:
                [float(x) for x in parts[1:4]]  # noqa: B018 - checks that they are numbers
                vertices.append(parts[1:4])
            except ValueError:
                raise ValueError(f"{path}: line {number}: a coordinate is not a number") from None
        elif parts[0] == "f":
            if len(parts) < 4:
                raise ValueError(f"{path}: line {number}: a face needs at least 3 vertices")
            n = len(vertices)
            try:
                face = [int(p.split("/")[0]) for p in parts[1:]]
            except ValueError:
                raise ValueError(f"{path}: line {number}: a vertex index is not a whole number") from None
            # OBJ counts from 1; a negative index counts back from the last vertex read so far.
            face = [i - 1 if i > 0 else n + i for i in face]
            if any(i < 0 for i in face):
                raise ValueError(f"{path}: line {number}: vertex index out of range")
            counts.append(len(face))
            indices.extend(face)
    return np.array(vertices, dtype=str).reshape(-1, 3), Faces(counts, indices)


def _decimals(text, dtype):
    """Decimal strings to `dtype`, correctly rounded (as std::from_chars). Through double, which is correctly
    rounded; to float32 that is right except where the double lands exactly halfway between two floats, where
    the decimal itself may lie on either side: those are settled exactly."""
    x = text.astype(np.float64)
    if np.dtype(dtype) == np.float64:
        return x
    f = x.astype(np.float32)
    other = np.where(x > f, np.nextafter(f, np.float32(np.inf)), np.nextafter(f, np.float32(-np.inf)))
    tie = (x != f) & ((f.astype(np.float64) + other.astype(np.float64)) / 2 == x)
    for i in zip(*np.nonzero(tie)):
        exact, half = Fraction(str(text[i], "ascii") if text.dtype.kind == "S" else text[i]), Fraction(x[i])
        if exact != half and (exact > half) == (other[i] > f[i]):
            f[i] = other[i]
    return f.astype(dtype, copy=False)


_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


def _read_ply(data, path):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError(f"{path}: malformed PLY: no 'ply' ... 'end_header' header")
    body = data.index(b"\n", end) + 1
    fmt, elements = None, []
    for line in data[:end].decode("ascii", "replace").splitlines()[1:]:
        p = line.split()
        if not p or p[0] in ("comment", "obj_info"):
            continue
        if p[0] == "format" and len(p) == 3:
            fmt = p[1]
        elif p[0] == "element" and len(p) == 3:
            elements.append((p[1], int(p[2]), []))
        elif p[0] == "property" and elements and len(p) == 3 and p[1] in _PLY_TYPES:
            elements[-1][2].append((p[2], _PLY_TYPES[p[1]], None))
        elif (
            p[0] == "property"
            and elements
            and len(p) == 5
            and p[1] == "list"
            and p[2] in _PLY_TYPES
            and p[3] in _PLY_TYPES
        ):
            elements[-1][2].append((p[4], _PLY_TYPES[p[3]], _PLY_TYPES[p[2]]))
        else:
            raise ValueError(f"{path}: malformed PLY header line: {line!r}")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"{path}: malformed PLY: unknown format {fmt!r}")
    order = "<" if fmt == "binary_little_endian" else ">"
    V, faces = None, Faces([], [])
    tokens = data[body:].split() if fmt == "ascii" else None
    pos = 0
    for name, count, props in elements:
        if fmt == "ascii":
            values, pos = _ply_ascii_element(tokens, pos, count, props, path, name)
        else:
            values, pos = _ply_binary_element(data, body + pos, count, props, order, path, name)
            pos -= body
        if name == "vertex":
            try:
                V = np.stack([values[c] for c in ("x", "y", "z")], axis=1)
            except KeyError:
                raise ValueError(f"{path}: the vertex element has no x, y and z") from None
        elif name == "face":
            lists = [v for (pname, _, ctype), v in zip(props, values.values()) if ctype is not None]
            if not lists:
                raise ValueError(f"{path}: the face element has no vertex index list")
            faces = Faces(*lists[0])
    if V is None:
        raise ValueError(f"{path}: no vertex element")
    if np.any(faces.counts < 3):
        raise ValueError(f"{path}: a face has fewer than 3 vertices")
    return V, faces


def _ply_ascii_element(tokens, pos, count, props, path, name):
    if all(ctype is None for _, _, ctype in props):
        width = len(props)
        block = tokens[pos : pos + count * width]
        if len(block) != count * width:
            raise ValueError(f"{path}: malformed PLY: truncated in element {name}")
        try:
            np.array(block, dtype=np.float64)
        except ValueError:
            raise ValueError(f"{path}: malformed PLY: a value of element {name} is not a number") from None
        table = np.array(block, dtype="S").reshape(count, width)  # the text: rounded to the precision later
        return {p: table[:, i] for i, (p, _, _) in enumerate(props)}, pos + count * width
    columns = {p: [] for p, _, _ in props}
    try:
        for _ in range(count):
            for p, _, ctype in props:
                if ctype is None:
                    float(tokens[pos])  # a number, or ValueError
                    columns[p].append(tokens[pos])
                    pos += 1
                else:
                    n = int(tokens[pos])
                    columns[p].append([int(t) for t in tokens[pos + 1 : pos + 1 + n]])
                    pos += 1 + n
    except (IndexError, ValueError):
        raise ValueError(f"{path}: malformed PLY: truncated or not a number in element {name}") from None
    for p, _, ctype in props:
        if ctype is None:
            columns[p] = np.array(columns[p], dtype="S")
        else:
            lists = columns[p]
            columns[p] = (
                np.array([len(x) for x in lists], np.int64),
                np.fromiter((i for x in lists for i in x), np.int64),
            )
    return columns, pos


def _ply_binary_element(data, pos, count, props, order, path, name):
    lists = [p for p in props if p[2] is not None]
    if not lists:
        dtype = np.dtype([(p, order + t) for p, t, _ in props])
        if pos + count * dtype.itemsize > len(data):
            raise ValueError(f"{path}: malformed PLY: truncated in element {name}")
        table = np.frombuffer(data, dtype, count, pos)
        return {p: table[p] for p, _, _ in props}, pos + count * dtype.itemsize
    if len(props) == 1 and count:
        # The usual face element, one list: read as fixed records when every list has the first one's length.
        ((p, t, ctype),) = props
        first = int(np.frombuffer(data, order + ctype, 1, pos)[0])
        record = np.dtype([("n", order + ctype), ("i", order + t, (first,))])
        if first > 0 and pos + count * record.itemsize <= len(data):
            table = np.frombuffer(data, record, count, pos)
            if np.all(table["n"] == first):
                return {
                    p: (table["n"].astype(np.int64), table["i"].astype(np.int64).ravel())
                }, pos + count * record.itemsize
    columns = {p: [] for p, _, _ in props}
    try:
        for _ in range(count):
            for p, t, ctype in props:
                if ctype is None:
                    columns[p].append(np.frombuffer(data, order + t, 1, pos)[0])
                    pos += np.dtype(t).itemsize
                else:
                    n = int(np.frombuffer(data, order + ctype, 1, pos)[0])
                    pos += np.dtype(ctype).itemsize
                    columns[p].append(np.frombuffer(data, order + t, n, pos))
                    pos += n * np.dtype(t).itemsize
    except ValueError:
        raise ValueError(f"{path}: malformed PLY: truncated in element {name}") from None
    for p, _, ctype in props:
        if ctype is not None:
            lists = columns[p]
            columns[p] = (
                np.array([len(x) for x in lists], np.int64),
                np.concatenate(lists).astype(np.int64) if lists else np.zeros(0, np.int64),
            )
    return columns, pos


# ---- writing ------------------------------------------------------------------------------------------------


def write_atomically(path, write, tag=""):
    """Calls write(file) on a temporary file beside `path`, then renames it to `path`: readers never see a part
    of a file, and a run that dies leaves at most a temporary file `.NAME.TAG.*.tmp` (remove_temporaries)."""
    folder, name = os.path.split(os.path.abspath(path))
    tmp = os.path.join(folder, f".{name}.{tag}.{uuid.uuid4().hex}.tmp")
    try:
        with open(tmp, "wb") as f:
            write(f)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def remove_temporaries(folder, tag):
    """Removes the temporary files write_atomically(..., tag) left in `folder` (runs that died); their count."""
    pattern = re.compile(r"^\..*\." + re.escape(tag) + r"\.[0-9a-f]{32}\.tmp$")
    removed = 0
    for name in os.listdir(folder):
        if pattern.match(name):
            try:
                os.unlink(os.path.join(folder, name))
                removed += 1
            except FileNotFoundError:
                pass
    return removed


def write_mesh(path, vertices, faces=None, tag=""):
    """Writes `vertices` (n, 3) and `faces` (Faces, or None) by the file name: .ply (binary little-endian),
    .obj, or .npy (the vertices alone), all or nothing (write_atomically). Returns the bytes written."""
    ext = os.path.splitext(path)[1].lower()
    V = np.ascontiguousarray(vertices)
    if ext == ".npy":
        write_atomically(path, lambda f: np.save(f, V), tag)
    elif ext == ".ply":
        write_atomically(path, lambda f: _write_ply(f, V, faces), tag)
    elif ext == ".obj":
        write_atomically(path, lambda f: _write_obj(f, V, faces), tag)
    else:
        raise ValueError(f"{path}: unknown output format (.ply, .obj, .npy)")
    return os.path.getsize(path)


def _write_ply(f, V, faces):
    scalar = "double" if V.dtype == np.float64 else "float"
    m = len(faces) if faces is not None else 0
    f.write(
        (
            f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\nproperty {scalar} x\n"
            f"property {scalar} y\nproperty {scalar} z\nelement face {m}\n"
            "property list uchar int vertex_indices\nend_header\n"
        ).encode()
    )
    f.write(np.ascontiguousarray(V, dtype="<f8" if scalar == "double" else "<f4").data)
    if m:
        f.write(faces.ply_block().data)


def _encode_ply_faces(faces):
    m = len(faces)
    if np.any(faces.counts > 255):
        raise ValueError("a face has more than 255 vertices (PLY's uchar count)")
    tri = faces.triangles()
    if tri is not None:
        rec = np.empty(m, np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
        rec["n"] = 3
        rec["i"] = tri
        return rec.view(np.uint8)
    # Each face: its count (one byte), then its indices (4 bytes each).
    starts = np.concatenate(([0], np.cumsum(1 + 4 * faces.counts)[:-1]))
    buf = np.zeros(int(m + 4 * faces.counts.sum()), np.uint8)
    buf[starts] = faces.counts
    offsets = np.repeat(starts + 1, faces.counts) + 4 * (
        np.arange(len(faces.indices)) - np.repeat(np.cumsum(faces.counts) - faces.counts, faces.counts)
    )
    idx = faces.indices.astype("<i4").view(np.uint8).reshape(-1, 4)
    for b in range(4):
        buf[offsets + b] = idx[:, b]
    return buf


def _write_obj(f, V, faces):
    # float32 needs 9 significant digits to read back the same, float64 17.
    digits = 17 if V.dtype == np.float64 else 9
    f.write("".join(f"v {x:.{digits}g} {y:.{digits}g} {z:.{digits}g}\n" for x, y, z in V.tolist()).encode())
    if faces is not None and len(faces):
        ends = np.cumsum(faces.counts)
        one = (faces.indices + 1).tolist()
        lines, start = [], 0
        for end in ends.tolist():
            lines.append("f " + " ".join(map(str, one[start:end])) + "\n")
            start = end
        f.write("".join(lines).encode())


# ---- the handles file -----------------------------------------------------------------------------------------


class Animation:
    """A resolved handles file: rest handles and one target set per output (the frames, or one).

    `points` (k, 3) and `segments` ((s, 3), (s, 3)) are the rest positions; `frames` a list of
    (points (k, 3), (segment_a (s, 3), segment_b (s, 3))) targets; `region` the vertex indices of "region" or
    None. Arrays have the dtype asked for; `targets(i)` gives frame i as keyword arguments of Deformer.deform."""

    def __init__(self, points, segments, frames, region, animated):
        self.points, self.segments, self.frames, self.region, self.animated = points, segments, frames, region, animated

    def session_arguments(self):
        """Keyword arguments of mlsdeform.Deformer for the rest pose."""
        kw = {}
        if len(self.points):
            kw["points"] = self.points
        if len(self.segments[0]):
            kw["segments"] = self.segments
        if self.region is not None:
            kw["region"] = self.region
        return kw

    def targets(self, i):
        points, segments = self.frames[i]
        kw = {}
        if len(points):
            kw["points"] = points
        if len(segments[0]):
            kw["segments"] = segments
        return kw


def _strip_comments(text):
    """JSON with // and /* */ comments (as the program reads it) to plain JSON; strings are kept as they are."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(text[i : j + 1])
            i = j + 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            if j < 0:
                raise ValueError("unterminated /* comment")
            out.append(" ")
            i = j + 2
        else:
            out.append(c)
            i += 1
    return "".join(out)


class _Node:
    def __init__(self, value, path, file):
        self.v, self.path, self.file = value, path, file

    def fail(self, message):
        raise ValueError(f"{self.file}: {self.path or '/'}: {message}")

    def has(self, key):
        return isinstance(self.v, dict) and key in self.v

    def __getitem__(self, key):
        return _Node(self.v[key], f"{self.path}/{key}", self.file)

    def items(self):
        return [_Node(x, f"{self.path}/{i}", self.file) for i, x in enumerate(self.v)]

    def require(self, kind, what):
        if not isinstance(self.v, kind):
            self.fail(f"expected {what}")

    def only_keys(self, keys):
        for k in self.v:
            if k not in keys:
                self.fail(f"unknown key \"{k}\" (expected one of {', '.join(sorted(keys))})")

    def number(self):
        if isinstance(self.v, bool) or not isinstance(self.v, (int, float)):
            self.fail("expected a number")
        return float(self.v)

    def index(self):
        if isinstance(self.v, bool) or not isinstance(self.v, int) or self.v < 0:
            self.fail("expected a vertex index (a whole number >= 0)")
        return self.v

    def vec3(self):
        if not isinstance(self.v, list) or len(self.v) != 3:
            self.fail("expected a position [x, y, z]")
        return [x.number() for x in self.items()]

    def vec3_pair(self):
        if not isinstance(self.v, list) or len(self.v) != 2:
            self.fail("expected two positions [[x, y, z], [x, y, z]]")
        return [x.vec3() for x in self.items()]


def _target(n, segment):
    if n.has("target") and n.has("offset"):
        n.fail('give "target" or "offset", not both')
    if n.has("target"):
        return ("absolute", n["target"].vec3_pair() if segment else [n["target"].vec3()])
    if n.has("offset"):
        return ("offset", [n["offset"].vec3()])
    return ("rest", None)


def _frame_entry(n, segment):
    if n.v is None:
        return None
    if isinstance(n.v, dict):
        n.only_keys({"target", "offset"})
        if not n.has("target") and not n.has("offset"):
            n.fail('expected "target" or "offset"')
        return _target(n, segment)
    return ("absolute", n.vec3_pair() if segment else [n.vec3()])


def _motion(n):
    m = {"axis": [0.0, 0.0, 1.0], "degrees": 0.0, "pivot": None, "translate": [0.0, 0.0, 0.0], "path": n.path}
    n.require(dict, 'a motion {"rotate": {...}, "translate": [dx, dy, dz]}')
    n.only_keys({"rotate", "translate"})
    if n.has("rotate"):
        r = n["rotate"]
        r.require(dict, 'a rotation {"axis": [x, y, z], "degrees": a, "pivot": [x, y, z]}')
        r.only_keys({"axis", "degrees", "pivot"})
        if not r.has("axis") or not r.has("degrees"):
            r.fail('missing "degrees"' if r.has("axis") else 'missing "axis"')
        axis = r["axis"].vec3()
        big = max(abs(x) for x in axis)
        if big == 0:
            r["axis"].fail("zero axis (a rotation needs a direction)")
        # As the program: scaled by the largest component, then to unit length.
        axis = [x / big for x in axis]
        norm = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
        m["axis"] = [x / norm for x in axis]
        m["degrees"] = r["degrees"].number()
        if r.has("pivot"):
            m["pivot"] = r["pivot"].vec3()
    if n.has("translate"):
        m["translate"] = n["translate"].vec3()
    return m


def _sin_cos_degrees(degrees):
    """sin and cos, exact at multiples of 90 degrees (the program's sin_cos_degrees)."""
    r = math.remainder(degrees, 360.0)
    q = round(r / 90)
    f = r - 90 * q
    s, c = math.sin(f * (math.pi / 180)), math.cos(f * (math.pi / 180))
    return {0: (s, c), 1: (c, -s), 2: (-s, -c), 3: (-c, s)}[(int(q) + 4) % 4]


def _rotation(a, degrees):
    """Rodrigues: R = c I + s [a]_x + (1 - c) a a^T, summed in the program's order."""
    s, c = _sin_cos_degrees(degrees)
    K = [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]]
    return [
        [(c * (1.0 if i == j else 0.0) + s * K[i][j]) + ((1 - c) * a[i]) * a[j] for j in range(3)] for i in range(3)
    ]


def read_handles(path, vertices, dtype=np.float32):
    """Reads a handles file (the program's format, docs/cli.md) and resolves it against `vertices` (n, 3):
    an Animation in `dtype`. ValueError names the file and the JSON path of a problem."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise ValueError(f"{path}: cannot read: {e.strerror or e}") from e
    try:
        root = _Node(json.loads(_strip_comments(text)), "", path)
    except ValueError as e:
        raise ValueError(f"{path}: invalid JSON: {e}") from None
    return _resolve(root, np.asarray(vertices), np.dtype(dtype), path)


def _resolve(root, V, dtype, path):
    root.require(dict, 'an object {"points": [...], "segments": [...], ...}')
    root.only_keys({"points", "segments", "frames", "region", "groups", "comment"})
    n = len(V)

    def vertex(node):
        i = node.index()
        if i >= n:
            node.fail(f"vertex index {i} out of range (the mesh has {n} vertices" + (f", 0 to {n - 1})" if n else ")"))
        return [float(x) for x in V[i]]

    points, segments = [], []
    if root.has("points"):
        root["points"].require(list, "an array of point handles")
        for h in root["points"].items():
            h.require(dict, 'a point handle {"vertex": i} or {"rest": [x, y, z]}')
            h.only_keys({"vertex", "rest", "target", "offset", "name"})
            if h.has("vertex") == h.has("rest"):
                h.fail('give "vertex" or "rest", not both' if h.has("vertex") else 'missing "vertex" or "rest"')
            rest = vertex(h["vertex"]) if h.has("vertex") else h["rest"].vec3()
            points.append({"rest": rest, "target": _target(h, False), "path": h.path})
    if root.has("segments"):
        root["segments"].require(list, "an array of segment handles")
        for h in root["segments"].items():
            h.require(dict, 'a segment handle {"vertices": [i, j]} or {"rest": [[x, y, z], [x, y, z]]}')
            h.only_keys({"vertices", "rest", "target", "offset", "name"})
            if h.has("vertices") == h.has("rest"):
                h.fail('give "vertices" or "rest", not both' if h.has("vertices") else 'missing "vertices" or "rest"')
            if h.has("vertices"):
                vs = h["vertices"]
                if not isinstance(vs.v, list) or len(vs.v) != 2:
                    vs.fail("expected two vertex indices [i, j]")
                a, b = (vertex(x) for x in vs.items())
            else:
                a, b = h["rest"].vec3_pair()
            segments.append({"a": a, "b": b, "target": _target(h, True), "path": h.path})
    if not points and not segments:
        root.fail('no handles (give at least one entry in "points" or "segments")')
    region = None
    if root.has("region"):
        r = root["region"]
        r.require(list, "an array of vertex indices")
        if not r.v:
            r.fail('no vertices (leave "region" out to deform the whole mesh)')
        first = {}
        for i, x in enumerate(r.items()):
            v = x.index()
            if v in first:
                x.fail(f"vertex {v} is listed twice (first at /region/{first[v]})")
            first[v] = i
            vertex(x)
        region = np.array(r.v, dtype=np.int64)
    groups = []
    if root.has("groups"):
        root["groups"].require(list, "an array of handle groups")
        owner = {"points": {}, "segments": {}}
        for g in root["groups"].items():
            g.require(dict, 'a group {"points": [...], "segments": [...], "rotate": ..., "translate": ...}')
            g.only_keys({"points", "segments", "rotate", "translate", "name"})
            members = {}
            for kind, count in (("points", len(points)), ("segments", len(segments))):
                members[kind] = []
                if g.has(kind):
                    g[kind].require(list, "an array of handle indices")
                    for x in g[kind].items():
                        i = x.index()
                        if i >= count:
                            x.fail(f"no {kind[:-1]} handle {i} (the file has {count})")
                        if i in owner[kind]:
                            x.fail(
                                f"{kind[:-1]} handle {i} is already in a group (at {owner[kind][i]}); "
                                "a handle can be in one group only"
                            )
                        owner[kind][i] = x.path
                        members[kind].append(i)
            if not members["points"] and not members["segments"]:
                g.fail('an empty group (give "points" or "segments")')
            motion = _motion(_Node({k: g.v[k] for k in ("rotate", "translate") if k in g.v}, g.path, g.file))
            groups.append({"points": members["points"], "segments": members["segments"], "motion": motion})
    frames = None
    if root.has("frames"):
        fr = root["frames"]
        fr.require(list, "an array of frames")
        if not fr.v:
            fr.fail('no frames (leave "frames" out for a single output)')
        frames = []
        for frame in fr.items():
            frame.require(dict, 'a frame {"points": [...], "segments": [...], "groups": [...]}')
            frame.only_keys({"points", "segments", "groups", "comment"})
            spec = {}
            for key, count, segment in (
                ("points", len(points), False),
                ("segments", len(segments), True),
                ("groups", len(groups), None),
            ):
                spec[key] = [None] * count
                if frame.has(key):
                    lst = frame[key]
                    lst.require(list, f"an array with one entry per {key[:-1]}")
                    if len(lst.v) != count:
                        lst.fail(
                            f"{len(lst.v)} entries, expected {count} (one per "
                            + ("group" if segment is None else "segment" if segment else "point")
                            + (" handle)" if segment is not None else ")")
                        )
                    spec[key] = [
                        (None if x.v is None else _motion(x)) if segment is None else _frame_entry(x, segment)
                        for x in lst.items()
                    ]
            frames.append(spec)

    def fit(values, where):
        a = np.array(values, dtype=np.float64).astype(dtype)
        if not np.isfinite(a).all():
            raise ValueError(f"{path}: {where}: coordinates too large for {dtype.name}")
        return a

    rest_points = fit([p["rest"] for p in points], "/points").reshape(-1, 3)
    rest_a = fit([s["a"] for s in segments], "/segments").reshape(-1, 3)
    rest_b = fit([s["b"] for s in segments], "/segments").reshape(-1, 3)
    for i in range(len(segments)):
        if np.array_equal(rest_a[i], rest_b[i]):
            raise ValueError(f"{path}: {segments[i]['path']}: zero-length segment (its two ends coincide)")
    centroid = []
    for g in groups:
        sx = sy = sz = 0.0
        for i in g["points"]:
            x = points[i]["rest"]
            sx, sy, sz = sx + x[0], sy + x[1], sz + x[2]
        for i in g["segments"]:
            a, b = segments[i]["a"], segments[i]["b"]
            sx, sy, sz = sx + (a[0] + b[0]), sy + (a[1] + b[1]), sz + (a[2] + b[2])
        count = float(len(g["points"]) + 2 * len(g["segments"]))
        centroid.append([sx / count, sy / count, sz / count])

    def moved(spec):
        q, qa, qb = [], [], []
        for i, p in enumerate(points):
            kind, value = (spec and spec["points"][i]) or p["target"]
            r = p["rest"]
            q.append(
                r if kind == "rest" else value[0] if kind == "absolute" else [r[j] + value[0][j] for j in range(3)]
            )
        for i, s in enumerate(segments):
            kind, value = (spec and spec["segments"][i]) or s["target"]
            a, b = s["a"], s["b"]
            if kind == "absolute":
                a, b = value
            elif kind == "offset":
                a = [a[j] + value[0][j] for j in range(3)]
                b = [b[j] + value[0][j] for j in range(3)]
            qa.append(a)
            qb.append(b)
        for g, group in enumerate(groups):
            mo = (spec and spec["groups"][g]) or group["motion"]
            R = _rotation(mo["axis"], mo["degrees"])
            c = mo["pivot"] if mo["pivot"] is not None else centroid[g]
            t = mo["translate"]

            def image(x):
                d = [x[0] - c[0], x[1] - c[1], x[2] - c[2]]
                return [((R[i][0] * d[0] + R[i][1] * d[1]) + R[i][2] * d[2] + c[i]) + t[i] for i in range(3)]

            for i in group["points"]:
                q[i] = image(points[i]["rest"])
            for i in group["segments"]:
                qa[i], qb[i] = image(segments[i]["a"]), image(segments[i]["b"])
        return (
            fit(q, "/points").reshape(-1, 3),
            (fit(qa, "/segments").reshape(-1, 3), fit(qb, "/segments").reshape(-1, 3)),
        )

    targets = [moved(None)] if frames is None else [moved(f) for f in frames]
    return Animation(rest_points, (rest_a, rest_b), targets, region, frames is not None)
