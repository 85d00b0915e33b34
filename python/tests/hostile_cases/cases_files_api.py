"""The Python face of the files library (mlsdeform.files: Mesh, write_mesh, DeformJob): bad arguments refused
with a message naming them, never a silent wrong file; a rigid motion of every handle carried through
Mesh.deformed gives every vertex that motion and every normal R n (numpy float64 the oracle); a Mesh built from
arrays written and read back bit for bit; a file the program refuses refused here with its message."""
import os
import tempfile

import numpy as np

import mlsdeform
from mlsdeform import files

from support import random_rotation

from .common import EPS, TYPE, VALUE, Wrong, add, refused, same, within
from .scenes import grid_mesh


def normals_mesh(tmp, g):
    """A grid written as a PLY with its normals computed (the program's writer): (path, vertices float64)."""
    V, F = grid_mesh(8, 8)
    V = (V + 0.01 * g.normal(size=V.shape)).astype(np.float32)
    path = os.path.join(tmp, "n.ply")
    files.write_mesh(path, files.Mesh.from_arrays(V, F), normals="computed")
    return path, V.astype(np.float64)


def build(args):
    def f(g):
        with tempfile.TemporaryDirectory() as tmp:
            path, V = normals_mesh(tmp, g)
            mesh = files.read_mesh(path)
            R, t = random_rotation(g), g.uniform(-2, 2, 3)
            pts = [0, 7, 56, 63, 20]
            d = mlsdeform.Deformer(mesh.vertices, points=mesh.vertices[pts])
            frames = mesh.frames_for("rigid")
            X = d.deform(points=(V[pts] @ R.T + t).astype(np.float32), **frames)
            posed = mesh.deformed(X, **frames)
            out = os.path.join(tmp, "o.ply")
            files.write_mesh(out, posed)
            back = files.read_mesh(out)
            # The motion on every vertex (the bound of motions.check_motion, float32: 16 (J + 16) eps |x|).
            within(back.vertices, V @ R.T + t, 16 * 21 * EPS[np.float32] * 8, "positions: the motion")
            n_in = read_normals(path)
            n_out = read_normals(out)
            within(n_out, n_in @ R.T, 64 * EPS[np.float32], "normals: R n")
            return "correct"

    add("files", "Mesh.deformed: a rigid motion of every handle carries positions and normals", f)

    def f(g):
        with tempfile.TemporaryDirectory() as tmp:
            path, _ = normals_mesh(tmp, g)
            mesh = files.read_mesh(path)
            return refused(lambda: mesh.deformed(mesh.vertices), VALUE, ["linear", "frames_for"])

    add("files", "Mesh.deformed without the frames its normals need: refused", f)

    def bad_frames(kind):
        def f(g):
            with tempfile.TemporaryDirectory() as tmp:
                path, _ = normals_mesh(tmp, g)
                mesh = files.read_mesh(path)
                n = len(mesh.vertices)
                L = {
                    "shape": np.zeros((n, 3)),
                    "rows": np.tile(np.eye(3), (n + 1, 1, 1)),
                    "strings": np.full((n, 3, 3), "a"),
                }[kind]
                return refused(lambda: mesh.deformed(mesh.vertices, linear=L), (VALUE, TYPE), ["linear"])

        return f

    for kind in ("shape", "rows", "strings"):
        add("files", f"Mesh.deformed with linear of the wrong {kind}: refused", bad_frames(kind))

    def f(g):
        with tempfile.TemporaryDirectory() as tmp:
            path, _ = normals_mesh(tmp, g)
            mesh = files.read_mesh(path)
            X = mesh.vertices
            X[3, 1] = np.nan
            L = np.tile(np.eye(3, dtype=np.float32), (len(X), 1, 1))
            return refused(
                lambda: files.write_mesh(os.path.join(tmp, "o.ply"), mesh.deformed(X, linear=L)),
                VALUE,
                ["finite", "nan"],
            )

    add("files", "Mesh.deformed at a NaN position: refused, nothing written", f)

    def bad_splat_frames(kind):
        def f(g):
            with tempfile.TemporaryDirectory() as tmp:
                path = os.path.join(tmp, "s.ply")
                names = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2"]
                names += ["rot_0", "rot_1", "rot_2", "rot_3"]
                rec = g.normal(size=(20, len(names))).astype("<f4")
                head = "ply\nformat binary_little_endian 1.0\nelement vertex 20\n"
                head += "".join(f"property float {p}\n" for p in names) + "end_header\n"
                open(path, "wb").write(head.encode() + rec.tobytes())
                mesh = files.read_mesh(path)
                q = np.tile(np.float32([1, 0, 0, 0]), (20, 1))
                s_ = np.ones(20, np.float32)
                if kind == "zero quaternion":
                    q[4] = 0
                elif kind == "NaN quaternion":
                    q[4, 2] = np.nan
                elif kind == "negative scale":
                    s_[3] = -1
                elif kind == "NaN scale":
                    s_[3] = np.nan
                elif kind == "too few rows":
                    q = q[:19]
                out = os.path.join(tmp, "o.ply")
                r = refused(
                    lambda: files.write_mesh(out, mesh.deformed(mesh.vertices, quaternions=q, scales=s_)),
                    VALUE,
                    ["quaternion", "scale", "finite", "rotation", "shape", "splat"],
                )
                if os.path.exists(out):
                    raise Wrong("a file was written")
                return r

        return f

    for kind in ("zero quaternion", "NaN quaternion", "negative scale", "NaN scale", "too few rows"):
        add("files", f"Mesh.deformed of splats with a {kind}: refused, nothing written", bad_splat_frames(kind))

    def f(g):
        V = g.normal(size=(30, 3)).astype(np.float32)
        F = g.integers(0, 30, (12, 3))
        with tempfile.TemporaryDirectory() as tmp:
            for ext in (".ply", ".obj", ".off", ".ply.gz"):
                p = os.path.join(tmp, "a" + ext)
                files.write_mesh(p, V, F)
                back = files.read_mesh(p)
                same(back.vertices, V, f"{ext}: vertices")
                same(back.faces.indices.reshape(-1, 3), F, f"{ext}: faces")
            p = os.path.join(tmp, "a.npy")
            files.write_mesh(p, V, F)
            same(np.load(p), V, ".npy: numpy reads the positions back")
        return "correct"

    add("files", "write_mesh from arrays: every format reads back bit for bit", f)

    def bad_arrays(what):
        def f(g):
            V = g.normal(size=(5, 3))
            F = {"index": [[0, 1, 9]], "negative": [[0, -1, 2]], "fraction": [[0, 1.5, 2]], "short": [[0, 1]]}[what]
            with tempfile.TemporaryDirectory() as tmp:
                p = os.path.join(tmp, "a.ply")
                r = refused(lambda: files.write_mesh(p, V, np.array(F)), (VALUE, TYPE), ["faces", "index", "expected"])
                if os.path.exists(p):
                    raise Wrong("a file was written")
                return r

        return f

    for what in ("index", "negative", "fraction", "short"):
        add("files", f"write_mesh with faces of a bad {what}: refused, nothing written", bad_arrays(what))

    def f(g):
        with tempfile.TemporaryDirectory() as tmp:
            p = os.path.join(tmp, "a.stl")
            return refused(lambda: files.write_mesh(p, np.zeros((3, 3))), VALUE, ["unknown output format"])

    add("files", "write_mesh to an unknown format: refused", f)

    def f(g):
        with tempfile.TemporaryDirectory() as tmp:
            return refused(lambda: files.read_mesh(tmp + "/"), VALUE, ["format", "directory"])

    add("files", "read_mesh of a folder: refused", f)

    def bad_job(option, value, words):
        def f(g):
            with tempfile.TemporaryDirectory() as tmp:
                path, _ = normals_mesh(tmp, g)
                h = os.path.join(tmp, "h.json")
                open(h, "w").write('{"points": [{"vertex": 0}, {"vertex": 9, "offset": [0, 1, 0]}]}')
                out = os.path.join(tmp, "o.ply")
                r = refused(lambda: files.DeformJob(path, h, out, **{option: value}), (VALUE, TYPE), words)
                if os.path.exists(out):
                    raise Wrong("a file was written")
                return r

        return f

    for option, value, words in (
        ("transform", "rigidd", ["transform"]),
        ("exponent", float("nan"), ["exponent", "weight"]),
        ("normals", "computer", ["normals"]),
        ("output_type", "float16", ["output_type"]),
        ("dtype", np.int32, ["dtype"]),
        ("threads", -3, ["threads"]),
        ("bogus", 1, ["bogus"]),
    ):
        add("files", f"DeformJob with {option}={value!r}: refused, nothing written", bad_job(option, value, words))

    def f(g):
        with tempfile.TemporaryDirectory() as tmp:
            path, _ = normals_mesh(tmp, g)
            h = os.path.join(tmp, "h.json")
            open(h, "w").write('{"points": [{"vertex": 0}]}')
            out = os.path.join(tmp, "o.ply")
            open(out, "w").write("mine")
            r = refused(lambda: files.DeformJob(path, h, out), VALUE, ["exists"])
            if open(out).read() != "mine":
                raise Wrong("an existing output was replaced")
            return r

    add("files", "DeformJob onto an existing output without overwrite: refused, the file kept", f)


def read_normals(path):
    """nx ny nz of a binary little-endian PLY whose vertex element is x y z nx ny nz (float), with numpy alone."""
    data = open(path, "rb").read()
    head = data[: data.index(b"end_header\n") + len(b"end_header\n")].decode()
    n = int(head.split("element vertex ")[1].split()[0])
    assert "property float nx" in head
    rec = np.frombuffer(data[len(head) : len(head) + 24 * n], "<f4").reshape(n, 6)
    return rec[:, 3:].astype(np.float64)
