"""The handles file for mlsdeform.files (the program's format, docs/cli.md): JSON with comments, resolved
against a mesh as the program resolves it (targets in double, rounded once to the session's precision)."""
import json
import math

import numpy as np


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
