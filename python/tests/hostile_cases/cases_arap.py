"""ARAP: against its bound, its refusals, the faces' dtypes."""
import numpy as np

import mlsdeform

from .common import (
    BadError,
    CLEAR,
    DTYPES,
    EPS,
    EPS64,
    SCALE_ACCEPT,
    TYPE,
    VALUE,
    add,
    finite,
    refused,
    same,
    within,
    words_in,
)
from .scenes import arap_tol, exact_scaling, grid_mesh, rigid


D_ = mlsdeform.Deformer


def build(args):
    # ---- ARAP ----
    for dt in DTYPES:
        for iterations in (1, 2, 5):
            for pose in ("rest", "rigid"):

                def f(g, dt=dt, iterations=iterations, pose=pose):
                    V, F = grid_mesh(8, 8, dt)
                    held = np.array([0, 7, 56, 63, 27])
                    P = V[held]
                    R, t, move = rigid(g)
                    Q = P if pose == "rest" else move(P).astype(dt)
                    X = D_(V, points=P, faces=F, arap_iterations=iterations).deform(points=Q)
                    want = V.astype(np.float64) if pose == "rest" else move(V)
                    within(
                        X, want, arap_tol(V.astype(np.float64), F, held, iterations, EPS[dt], 2), f"ARAP {pose} pose"
                    )

                add("arap", f"{pose} pose, {iterations} iterations {np.dtype(dt).name}", f)

            def f(g, dt=dt, iterations=iterations):
                V, F = grid_mesh(8, 8, dt)
                held = np.array([0, 7, 56, 63])
                Q = V[held].copy()
                Q[3, 2] += dt(0.5)
                X = D_(V, points=V[held], faces=F, arap_iterations=iterations).deform(points=Q)
                finite(X)
                same(X[held], Q, "handles on vertices are held at their targets")

            add("arap", f"handles on vertices exact, {iterations} iterations {np.dtype(dt).name}", f)
        for e in (-120, -70, -20, 20, 70, 120) if dt == np.float32 else (-1000, -500, -200, 200, 500, 1000):

            def f(g, dt=dt, e=e):
                V, F = grid_mesh(10, 10, np.float64)
                held = np.array([0, 9, 90, 99, 45])
                Q = V[held] + g.normal(scale=0.1, size=(5, 3))
                V, Q = exact_scaling(e, dt, V, Q)

                def run(s):
                    def sc(X):
                        return np.ldexp(X, s).astype(dt)

                    return D_(sc(V), points=sc(V[held]), faces=F, arap_iterations=2).deform(points=sc(Q))

                X0 = run(0).astype(np.float64)
                Xs = run(e)
                finite(Xs, f"ARAP x 2^{e}")
                # Scale-free algebra on power-of-two-scaled input: twice the bound of one ARAP result.
                tol = 2 * arap_tol(V, F, held, 2, EPS[dt], 2)
                within(np.ldexp(Xs.astype(np.float64), -e), X0, tol, f"ARAP x 2^{e}, divided back")

            add("scale-arap", f"ARAP scene x 2^{e} {np.dtype(dt).name}", f, accept=SCALE_ACCEPT)
    arap_errors = [
        ("faces (m, 2)", lambda V, F: D_(V, points=V[:3], faces=F[:, :2], arap_iterations=1), VALUE, ["faces"]),
        (
            "faces out of range",
            lambda V, F: D_(V, points=V[:3], faces=F + len(V), arap_iterations=1),
            VALUE,
            ["outside", "range", "vertex"],
        ),
        (
            "negative face index",
            lambda V, F: D_(V, points=V[:3], faces=F - 1, arap_iterations=1),
            VALUE,
            ["faces", "range"],
        ),
        (
            "faces 2.5",
            lambda V, F: D_(V, points=V[:3], faces=np.where(F == 5, 2.5, F), arap_iterations=1),
            VALUE,
            ["faces", "2.5"],
        ),
        (
            "faces NaN",
            lambda V, F: D_(V, points=V[:3], faces=np.where(F == 5, np.nan, F), arap_iterations=1),
            VALUE,
            ["faces", "nan"],
        ),
        ("faces bool", lambda V, F: D_(V, points=V[:3], faces=F > 3, arap_iterations=1), TYPE, ["faces"]),
        ("faces strings", lambda V, F: D_(V, points=V[:3], faces=F.astype(str), arap_iterations=1), TYPE, ["faces"]),
        ("faces complex", lambda V, F: D_(V, points=V[:3], faces=F + 0j, arap_iterations=1), TYPE, ["faces"]),
        (
            "faces uint64 max",
            lambda V, F: D_(V, points=V[:3], faces=np.full(F.shape, 2**64 - 1, np.uint64), arap_iterations=1),
            VALUE,
            ["faces"],
        ),
        (
            "faces 1e300",
            lambda V, F: D_(V, points=V[:3], faces=np.full(F.shape, 1e300), arap_iterations=1),
            VALUE,
            ["faces"],
        ),
        (
            "arap with region",
            lambda V, F: D_(V, points=V[:3], faces=F, arap_iterations=1, region=[0, 1, 2]),
            VALUE,
            ["region", "arap"],
        ),
        (
            "arap_iterations 2.0",
            lambda V, F: D_(V, points=V[:3], faces=F, arap_iterations=2.0),
            TYPE,
            ["incompatible", "arap"],
        ),
        (
            "no faces, empty array",
            lambda V, F: D_(V, points=V[:3], faces=np.zeros((0, 3), int), arap_iterations=1),
            VALUE,
            ["triangles", "faces"],
        ),
    ]
    for name, call, exc, words in arap_errors:

        def f(g, call=call, exc=exc, words=words):
            V, F = grid_mesh(5, 5)
            return refused(lambda: call(V, F), exc, words)

        add("arap-errors", name, f)
    for kind in ("float64", "float32", "list", "uint16", "int32", "F-order"):

        def f(g, kind=kind):
            V, F = grid_mesh(6, 6)
            held = np.array([0, 5, 30, 35])
            Q = V[held] + [[0, 0, 0], [0, 0, 0.3], [0, 0.2, 0], [0.1, 0, 0]]
            want = D_(V, points=V[held], faces=F, arap_iterations=2).deform(points=Q)
            Fk = {
                "float64": F.astype(np.float64),
                "float32": F.astype(np.float32),
                "list": F.tolist(),
                "uint16": F.astype(np.uint16),
                "int32": F.astype(np.int32),
                "F-order": np.asfortranarray(F),
            }[kind]
            same(D_(V, points=V[held], faces=Fk, arap_iterations=2).deform(points=Q), want, f"faces as {kind}")

        add("integers", f"faces as {kind} (integral values)", f)
    for kind in (
        "degenerate triangle",
        "repeated vertex in a face",
        "isolated vertex",
        "duplicate face",
        "non-manifold edge",
    ):

        def f(g, kind=kind):
            V, F = grid_mesh(6, 6)
            if kind == "degenerate triangle":
                V = np.vstack([V, V[14] + [0, 0, 0], (V[14] + V[15]) / 2])
                F = np.vstack([F, [[14, 36, 37]]])
            elif kind == "repeated vertex in a face":
                F = np.vstack([F, [[3, 3, 4]]])
            elif kind == "isolated vertex":
                V = np.vstack([V, [[0.5, 0.5, 1]]])
            elif kind == "duplicate face":
                F = np.vstack([F, F[:3]])
            else:
                V = np.vstack([V, [[0.1, 0.1, 1]]])
                F = np.vstack([F, [[F[0][0], F[0][1], len(V) - 1]]])
            held = np.array([0, 5, 30, 35])
            try:
                X = D_(V, points=V[held], faces=F, arap_iterations=2).deform(points=V[held])
            except ValueError as e:
                if words_in(str(e), ["face", "triangle", "degenerate", "vertex", "mesh"]):
                    return CLEAR
                raise BadError(str(e))
            # Nothing moved: the rest pose comes back whatever the mesh's defects (the bound of a clean sheet
            # of the same size; a defect that the refiner mishandles shows as NaN or a visible displacement).
            Vc, Fc = grid_mesh(6, 6)
            within(X, V, arap_tol(Vc, Fc, held, 2, EPS64, 2) * 10, f"{kind}: rest pose")

        add("arap", f"{kind}: rest pose", f)
