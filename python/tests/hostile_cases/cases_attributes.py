"""The program's attributes (only with --cli): normals of OBJ and PLY files turned by a rigid motion of every
handle (point handles on vertices, segments on vertices, both), every other property passed through bit for
bit, normals outside a region written as read, --normals computed on a point cloud."""
import json
import os
import subprocess
import tempfile

import numpy as np

from support import random_rotation

from .common import CLEAR, EPS, BadError, Skip, Wrong, add, within
from .motions import conditioning, effective_kappa, rotation_bound
from .scenes import grid_mesh


def axis_angle(R):
    """(unit axis, degrees) of a rotation matrix (float64)."""
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if np.linalg.norm(w) < 1e-9:
        w = np.array([0.0, 0, 1])
    return w / np.linalg.norm(w), np.degrees(angle)


def rotation(axis, degrees):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = np.radians(degrees)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def run(program, args, tmp):
    r = subprocess.run([program] + args + ["--quiet"], capture_output=True, text=True, timeout=50, cwd=tmp)
    return r


def write_obj(path, V, N, F):
    with open(path, "w") as fh:
        for v in V:
            fh.write("v %r %r %r\n" % tuple(float(x) for x in v))
        for n in N:
            fh.write("vn %r %r %r\n" % tuple(float(x) for x in n))
        for f in F:
            fh.write("f " + " ".join(f"{i + 1}//{i + 1}" for i in f) + "\n")


def read_obj(path):
    V, N, corners = [], [], []
    with open(path) as fh:
        for line in fh:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                V.append([float(x) for x in p[1:4]])
            elif p[0] == "vn":
                N.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                for c in p[1:]:
                    v, _, n = c.split("/")
                    corners.append((int(v) - 1, int(n) - 1))
    return np.array(V), np.array(N), corners


def normals_case(program, g, handles_kind, precision, transform):
    """A 9 x 9 sheet with one vn per vertex, handles on vertices, every handle moved by one rigid motion (a
    group): every vertex must land on R v + t and every face corner's normal be R n (docs/cli.md: the handles'
    own vertices too)."""
    if not program:
        raise Skip("no program (--cli or MLSDEFORM_CLI)")
    dt = np.float64 if precision == "double" else np.float32
    V, F = grid_mesh(9, 9)
    V = V.astype(dt).astype(np.float64)
    N = g.normal(size=V.shape)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    N = N.astype(dt).astype(np.float64)
    pts = [0, 8, 40, 72, 80] if handles_kind != "segments" else []
    segs = {"points": [], "segments": [[10, 16], [64, 70]], "mixed": [[20, 24]]}[handles_kind]
    axis = g.normal(size=3)
    degrees = float(g.uniform(20, 170))
    t = g.uniform(-1, 1, 3)
    spec = {
        "points": [{"vertex": i} for i in pts],
        "segments": [{"vertices": s} for s in segs],
        "groups": [
            {
                "points": list(range(len(pts))),
                "segments": list(range(len(segs))),
                "rotate": {"axis": axis.tolist(), "degrees": degrees, "pivot": [0, 0, 0]},
                "translate": t.tolist(),
            }
        ],
    }
    if not pts:
        del spec["points"]
        del spec["groups"][0]["points"]
    if not segs:
        del spec["segments"]
        del spec["groups"][0]["segments"]
    R = rotation(axis, degrees)
    with tempfile.TemporaryDirectory() as tmp:
        write_obj(os.path.join(tmp, "in.obj"), V, N, F)
        with open(os.path.join(tmp, "h.json"), "w") as fh:
            json.dump(spec, fh)
        r = run(
            program,
            ["deform", "-m", "in.obj", "-H", "h.json", "-o", "out.obj", "--precision", precision]
            + ["--transform", transform],
            tmp,
        )
        if r.returncode != 0:
            raise BadError(f"exit {r.returncode}: {r.stderr[-300:]}")
        X, Nout, corners = read_obj(os.path.join(tmp, "out.obj"))
    P = V[pts]
    a = np.array([V[s[0]] for s in segs]).reshape(-1, 3)
    b = np.array([V[s[1]] for s in segs]).reshape(-1, 3)
    kf, ko, arm = conditioning(V, P, a, b, "paper_constant", 2.0, "rigid")
    kappa = effective_kappa(kf, ko, dt, ~np.isfinite(kf))
    # The targets are the group's image computed in double and rounded to the precision (docs/cli.md); the
    # fit's bound as in motions.check_motion; the text written is the shortest that reads back exactly.
    tolR = rotation_bound(kappa, EPS[dt])
    J = len(pts) + 2 * len(segs)
    scale = max(np.abs(V).max(), np.abs(V @ R.T + t).max(), 1.0)
    within(X, V @ R.T + t, 16 * (J + 16) * EPS[dt] * scale + tolR * arm, "positions")
    vs = np.array([c[0] for c in corners])
    ns = np.array([c[1] for c in corners])
    # A normal R n renormalised: the rotation's error plus the renormalisation's 4 eps.
    within(Nout[ns], N[vs] @ R.T, tolR[vs] + 4 * EPS[dt], "normals R n at every corner")


def ply_case(program, g, binary):
    """A PLY point set with normals, colours (uchar), a quality (float) and a label (int): every handle moved
    rigidly; colours, quality and labels bit for bit, normals R n, positions R v + t."""
    if not program:
        raise Skip("no program (--cli or MLSDEFORM_CLI)")
    n = 60
    V = g.uniform(-1, 1, (n, 3)).astype(np.float32)
    N = g.normal(size=(n, 3))
    N = (N / np.linalg.norm(N, axis=1, keepdims=True)).astype(np.float32)
    col = g.integers(0, 256, (n, 3)).astype(np.uint8)
    qual = g.normal(size=n).astype(np.float32)
    lab = g.integers(-(2**31), 2**31 - 1, n).astype(np.int32)
    rec = np.zeros(
        n,
        dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
        + [("red", "u1"), ("green", "u1"), ("blue", "u1"), ("quality", "<f4"), ("label", "<i4")],
    )
    for i, k in enumerate("xyz"):
        rec[k] = V[:, i]
        rec["n" + k] = N[:, i]
    for i, k in enumerate(("red", "green", "blue")):
        rec[k] = col[:, i]
    rec["quality"], rec["label"] = qual, lab
    props = "".join(
        f"property {t} {k}\n"
        for k, t in zip(rec.dtype.names, ["float"] * 6 + ["uchar"] * 3 + ["float", "int"])  # noqa: B905
    )
    header = f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\n{props}end_header\n"
    pts = [0, 11, 23, 37, 52]
    R = random_rotation(g)
    axis, degrees = axis_angle(R)
    R = rotation(axis, degrees)
    t = g.uniform(-1, 1, 3)
    spec = {
        "points": [{"vertex": i} for i in pts],
        "groups": [
            {"points": list(range(5)), "rotate": {"axis": axis.tolist(), "degrees": degrees, "pivot": [0, 0, 0]}}
        ],
    }
    spec["groups"][0]["translate"] = t.tolist()
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "in.ply"), "wb") as fh:
            fh.write(header.encode() + rec.tobytes())
        with open(os.path.join(tmp, "h.json"), "w") as fh:
            json.dump(spec, fh)
        extra = [] if binary else ["--ply-ascii"]
        r = run(program, ["deform", "-m", "in.ply", "-H", "h.json", "-o", "out.ply"] + extra, tmp)
        if r.returncode != 0:
            raise BadError(f"exit {r.returncode}: {r.stderr[-300:]}")
        data = open(os.path.join(tmp, "out.ply"), "rb").read()
    head, _, body = data.partition(b"end_header\n")
    if binary:
        out = np.frombuffer(body, rec.dtype, count=n)
    else:
        rows = [line.split() for line in body.decode().splitlines() if line.strip()]
        out = np.zeros(n, rec.dtype)
        for i, row in enumerate(rows[:n]):
            out[i] = tuple(float(x) if j < 6 or j == 9 else int(x) for j, x in enumerate(row))
    for k in ("red", "green", "blue", "quality", "label"):
        if out[k].tobytes() != rec[k].tobytes():
            raise Wrong(f"property {k} not passed through bit for bit")
    X = np.stack([out[k] for k in "xyz"], 1).astype(np.float64)
    No = np.stack([out["n" + k] for k in "xyz"], 1).astype(np.float64)
    V64 = V.astype(np.float64)
    kf, ko, arm = conditioning(V64, V64[pts], None, None, "paper_constant", 2.0, "rigid")
    kappa = effective_kappa(kf, ko, np.float32, ~np.isfinite(kf))
    tolR = rotation_bound(kappa, EPS[np.float32])
    within(X, V64 @ R.T + t, 16 * 21 * EPS[np.float32] * 3 + tolR * arm, "positions")
    within(No, N.astype(np.float64) @ R.T, tolR + 4 * EPS[np.float32], "normals R n")


def region_case(program, g):
    """Normals outside a region (any length, 3 included) are written exactly as read (docs/cli.md)."""
    if not program:
        raise Skip("no program (--cli or MLSDEFORM_CLI)")
    V, F = grid_mesh(8, 8)
    N = g.normal(size=V.shape) * 3
    texts = [" ".join(repr(float(x)) for x in n) for n in N]
    region = [i for i in range(len(V)) if V[i, 0] < 0.4]
    spec = {"points": [{"vertex": 0, "offset": [0, 0, 0.3]}, {"vertex": 7}, {"vertex": 17}], "region": region}
    with tempfile.TemporaryDirectory() as tmp:
        write_obj(os.path.join(tmp, "in.obj"), V, N, F)
        with open(os.path.join(tmp, "in.obj")) as fh:
            lines = fh.read().splitlines()
        with open(os.path.join(tmp, "in.obj"), "w") as fh:
            fh.write(
                "\n".join(
                    line if not line.startswith("vn") else "vn " + texts[i - len(V)] for i, line in enumerate(lines)
                )
            )
            fh.write("\n")
        with open(os.path.join(tmp, "h.json"), "w") as fh:
            json.dump(spec, fh)
        r = run(program, ["deform", "-m", "in.obj", "-H", "h.json", "-o", "out.obj"], tmp)
        if r.returncode != 0:
            raise BadError(f"exit {r.returncode}: {r.stderr[-300:]}")
        vn_text = [line[3:].strip() for line in open(os.path.join(tmp, "out.obj")) if line.startswith("vn ")]
        _, _, corners = read_obj(os.path.join(tmp, "out.obj"))
    inside = set(region)
    # As read: the value the precision (float, the default) reads from the input's text, bit for bit (the
    # output's text is the shortest that reads back to it, so texts are compared as the floats they read to).
    bad = [
        v
        for v, nidx in corners
        if v not in inside
        and np.array([float(x) for x in vn_text[nidx].split()], np.float32).tobytes()
        != np.array([float(x) for x in texts[v].split()], np.float32).tobytes()
    ]
    # A region vertex's ring of outside vertices is held at rest: they are outside, their frames the identity.
    if bad:
        raise Wrong(f"{len(bad)} corners outside the region with normals not written as read (vertex {bad[0]})")


def computed_on_cloud(program, g):
    """--normals computed on a point cloud (no faces): refused (exit 2 naming the file), or the input's
    normals kept and stderr saying so; never zeros written over them."""
    if not program:
        raise Skip("no program (--cli or MLSDEFORM_CLI)")
    n = 20
    V = g.uniform(-1, 1, (n, 3))
    N = g.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "in.ply"), "w") as fh:
            fh.write(f"ply\nformat ascii 1.0\nelement vertex {n}\n")
            fh.write("".join(f"property double {k}\n" for k in ("x", "y", "z", "nx", "ny", "nz")) + "end_header\n")
            for v, m in zip(V, N):
                fh.write(" ".join(repr(float(x)) for x in list(v) + list(m)) + "\n")
        with open(os.path.join(tmp, "h.json"), "w") as fh:
            json.dump({"points": [{"vertex": 0}, {"vertex": 5, "offset": [0, 0.2, 0]}, {"vertex": 9}]}, fh)
        r = subprocess.run(
            [program, "deform", "-m", "in.ply", "-H", "h.json", "-o", "out.ply", "--normals", "computed"],
            capture_output=True,
            text=True,
            timeout=50,
            cwd=tmp,
        )
        if r.returncode == 2:
            if "in.ply" in r.stderr or "face" in r.stderr:
                return CLEAR
            raise BadError(f"exit 2 naming neither the file nor faces: {r.stderr[-200:]}")
        if r.returncode != 0:
            raise BadError(f"exit {r.returncode}: {r.stderr[-200:]}")
        head, _, body = open(os.path.join(tmp, "out.ply"), "rb").read().partition(b"end_header\n")
        names = [line.split()[-1] for line in head.decode().splitlines() if line.startswith("property")]
        if b"ascii" in head:
            rows = np.array([[float(x) for x in row.split()] for row in body.decode().splitlines() if row.strip()])
        else:
            types = [line.split()[1] for line in head.decode().splitlines() if line.startswith("property")]
            dt = np.dtype([(k, "<f8" if t == "double" else "<f4") for k, t in zip(names, types)])
            raw = np.frombuffer(body, dt, count=n)
            rows = np.stack([raw[k].astype(np.float64) for k in names], 1)
        No = rows[:, [names.index(k) for k in ("nx", "ny", "nz")]]
    if np.any(np.linalg.norm(No, axis=1) == 0):
        raise Wrong("zero normals written over the input's")
    if "normal" not in r.stderr.lower():
        raise Wrong("--normals computed not honoured, and stderr does not say so")


def build(args):
    cli = args.cli
    for kind in ("points", "segments", "mixed"):
        for precision in ("float", "double"):
            for transform in ("rigid", "similarity"):

                def f(g, kind=kind, precision=precision, transform=transform):
                    normals_case(cli, g, kind, precision, transform)

                add("cli-attributes", f"OBJ vn under a rigid motion: {kind} handles, {precision}, {transform}", f)
    for binary in (True, False):
        for rep in range(2):

            def f(g, binary=binary):
                ply_case(cli, g, binary)

            add("cli-attributes", f"PLY normals, colours, quality, label {'binary' if binary else 'ASCII'} #{rep}", f)
    for rep in range(2):
        add("cli-attributes", f"normals outside a region as read #{rep}", lambda g: region_case(cli, g))
    add("cli-attributes", "--normals computed on a point cloud", lambda g: computed_on_cloud(cli, g))


def cube_case(program, g, precision):
    """A flat-shaded cube (6 vn shared by the corners of a face, docs/cli.md: each (vn, vertex) pair becomes its
    own vn) with vt, groups, materials, smoothing, comments and a polyline, every corner a point handle, all
    moved by one rigid motion: every corner's normal R n, every vertex R v + t, every other line verbatim and
    in order."""
    if not program:
        raise Skip("no program (--cli or MLSDEFORM_CLI)")
    dt = np.float64 if precision == "double" else np.float32
    V = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) * 1.5 - 0.4
    faces = [(0, 1, 3, 2, (-1, 0, 0)), (4, 6, 7, 5, (1, 0, 0)), (0, 4, 5, 1, (0, -1, 0))]
    faces += [(2, 3, 7, 6, (0, 1, 0)), (0, 2, 6, 4, (0, 0, -1)), (1, 5, 7, 3, (0, 0, 1))]
    other = ["# a cube", "mtllib cube.mtl", "o cube", "vt 0 0", "vt 1 0", "vt 1 1", "g sides", "usemtl red", "s off"]
    lines = other[:3] + ["v %r %r %r" % tuple(map(float, v)) for v in V] + other[3:]
    lines += ["vn %d %d %d" % f[4] for f in faces]
    for k, f in enumerate(faces):
        lines.append("f " + " ".join(f"{i + 1}/{(j % 3) + 1}/{k + 1}" for j, i in enumerate(f[:4])))
    lines += ["l 1 2", "# end"]
    R = random_rotation(g)
    axis, degrees = axis_angle(R)
    R = rotation(axis, degrees)
    t = g.uniform(-1, 1, 3)
    spec = {
        "points": [{"vertex": i} for i in range(8)],
        "groups": [
            {
                "points": list(range(8)),
                "rotate": {"axis": axis.tolist(), "degrees": degrees, "pivot": [0, 0, 0]},
                "translate": t.tolist(),
            }
        ],
    }
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "in.obj"), "w") as fh:
            fh.write("\n".join(lines) + "\n")
        with open(os.path.join(tmp, "h.json"), "w") as fh:
            json.dump(spec, fh)
        r = run(program, ["deform", "-m", "in.obj", "-H", "h.json", "-o", "out.obj", "--precision", precision], tmp)
        if r.returncode != 0:
            raise BadError(f"exit {r.returncode}: {r.stderr[-300:]}")
        out = open(os.path.join(tmp, "out.obj")).read().splitlines()
        X, Nout, corners = read_obj(os.path.join(tmp, "out.obj"))
    # The program stamps its own first line (its reader drops it again: core/files/formats/obj_read.cpp).
    if out and out[0].startswith("# written by mlsdeform "):
        out = out[1:]
    kept = [x for x in out if not x.startswith(("v ", "vn ", "f "))]
    if kept != [x for x in lines if not x.startswith(("v ", "vn ", "f "))]:
        raise Wrong(f"other lines not kept verbatim and in order: {kept}")
    vt_text = [x.split()[1].split("/")[1] for x in out if x.startswith("f ")]
    if vt_text != [x.split()[1].split("/")[1] for x in lines if x.startswith("f ")]:
        raise Wrong("the corners' vt indices were rewritten")
    # Every vertex is a handle: each lands on its target, the motion's image rounded once to the precision;
    # the frame on a handle is the fit's limit there (motions.py, on handles), conditioned by the others.
    V64 = V.astype(dt).astype(np.float64)
    kf, ko, arm = conditioning(V64, V64, None, None, "paper_constant", 2.0, "rigid")
    kappa = effective_kappa(kf, ko, dt, ~np.isfinite(kf))
    tolR = rotation_bound(kappa, EPS[dt])
    within(X, V64 @ R.T + t, 4 * EPS[dt] * 3 * np.ones(8), "corners on their targets")
    normals = {k + 1: np.array(f[4], float) for k, f in enumerate(faces)}
    src = {}
    for line in lines:
        if line.startswith("f "):
            for c in line.split()[1:]:
                v, _, n = c.split("/")
                src.setdefault(int(v) - 1, []).append(normals[int(n)])
    want = []
    for v, _ in corners:
        want.append(src[v].pop(0))
    vs = np.array([c[0] for c in corners])
    within(Nout[[c[1] for c in corners]], np.array(want) @ R.T, tolR[vs] + 4 * EPS[dt], "corner normals R n")


def build_cube(args):
    cli = args.cli
    for precision in ("float", "double"):
        for rep in range(2):

            def f(g, precision=precision):
                cube_case(cli, g, precision)

            add("cli-attributes", f"flat-shaded cube, every line kept, {precision} #{rep}", f)
