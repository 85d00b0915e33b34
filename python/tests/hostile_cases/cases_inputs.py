"""The deformer's inputs: layouts and dtypes (bitwise the same as the C-contiguous array), NaN and
infinities, empty arrays and wrong counts, out= holding the handles."""
import numpy as np

import mlsdeform

from .common import CORRECT, DTYPES, INDEX, Skip, TYPE, VALUE, Wrong, add, refused, same
from .references import check_mls
from .scenes import cloud, misaligned


D_ = mlsdeform.Deformer


def build(args):
    # Layouts and dtypes of the inputs: the same as the C-contiguous array, bitwise.
    in_layouts = {
        "F-order": np.asfortranarray,
        "reversed view": lambda X: X[::-1].copy()[::-1],
        "strided view": lambda X: np.repeat(X, 2, axis=0)[::2],
        "column-strided": lambda X: np.repeat(X, 2, axis=1)[:, ::2],
        "list": lambda X: X.tolist(),
        "read-only": lambda X: np.frombuffer(X.tobytes(), X.dtype).reshape(X.shape),
        "misaligned": misaligned,
    }
    for dt in DTYPES:
        for name, make in in_layouts.items():
            for which in ("vertices", "points", "moved points", "segments", "out"):
                if which == "out" and name in (
                    "F-order",
                    "reversed view",
                    "strided view",
                    "column-strided",
                    "list",
                    "read-only",
                ):
                    continue

                def f(g, dt=dt, make=make, which=which, name=name):
                    V, P, Q, A, B, C, D = cloud(g, n=150, k=5, s=1, dtype=dt)
                    want = D_(V, points=P, segments=(A, B)).deform(points=Q, segments=(C, D))

                    def conv(X):
                        return make(X) if name != "list" else np.asarray(make(X), dt).tolist()

                    args = dict(V=V, P=P, Q=Q, A=A)
                    if which == "vertices":
                        args["V"] = conv(V)
                    elif which == "points":
                        args["P"] = conv(P)
                    elif which == "moved points":
                        args["Q"] = conv(Q)
                    elif which == "segments":
                        args["A"] = conv(A)
                    d = D_(args["V"], points=args["P"], segments=(args["A"], B), dtype=dt)
                    if which == "out":
                        out = make(np.zeros_like(V))
                        d.deform(points=Q, segments=(C, D), out=out)
                        same(np.ascontiguousarray(out), want, f"out {name}")
                    else:
                        same(d.deform(points=args["Q"], segments=(C, D)), want, f"{which} {name}")

                add("deform-layout", f"{which} {name} {np.dtype(dt).name}", f)

    in_dtypes = [
        ("int64", lambda X: np.round(X * 10).astype(np.int64), None),
        ("int8", lambda X: np.round(X * 10).astype(np.int8), None),
        ("float16", lambda X: X.astype(np.float16), None),
        ("bool", lambda X: X > 0, None),
        ("object", lambda X: X.astype(object), None),
        ("numeric strings", lambda X: X.astype(str), None),
        ("complex", lambda X: X + 1j, (TYPE, ["real"])),
        ("complex, zero imaginary", lambda X: X + 0j, (TYPE, ["real", "complex"])),
        ("timedelta", lambda X: X.astype("m8[s]"), (TYPE, ["real"])),
        ("words", lambda X: np.full(X.shape, "abc"), (TYPE, ["expected"])),
        ("None inside", lambda X: [[None, 0, 0]] * len(X), ((TYPE, VALUE), ["finite", "expected"])),
    ]
    for name, make, err in in_dtypes:
        for which in ("vertices", "points", "moved points"):

            def f(g, make=make, err=err, which=which):
                V, P, Q, *_ = cloud(g, n=60, k=5)
                V, P, Q = V * 3, P * 3, Q * 3
                conv = {"vertices": V, "points": P, "moved points": Q}[which]
                given = make(conv)
                exact = np.asarray(given, np.float64) if err is None else None

                def run():
                    if which == "vertices":
                        return D_(given, points=P).deform(points=Q)
                    if which == "points":
                        return D_(V, points=given).deform(points=Q)
                    return D_(V, points=P).deform(points=given)

                if err is not None:
                    return refused(
                        run,
                        err[0],
                        err[1] + [{"vertices": "vertices", "points": "points", "moved points": "points"}[which]],
                    )
                X = run()
                Vr, Pr, Qr = (
                    exact if which == "vertices" else V,
                    exact if which == "points" else P,
                    exact if which == "moved points" else Q,
                )
                if len(np.unique(Pr, axis=0)) < 4 or np.linalg.matrix_rank(Pr - Pr.mean(0)) < 3:
                    raise Skip("the converted handles are degenerate")
                check_mls(X, Vr, Pr, Qr, np.float64, what=f"{which} as {name}")

            # Booleans as handle positions put several handles on one corner with different targets:
            # a refusal that says so is the right answer.
            add(
                "deform-dtype",
                f"{which} as {name}",
                f,
                accept=(VALUE, ["share their rest position"]) if (name, which) == ("bool", "points") else None,
            )

    # NaN, infinities and coordinates too large: ValueError, out untouched.
    for dt in DTYPES:
        # Beyond max(T)/64 (docs/api.md): targets and group images are refused; rest positions are not
        # limited, so "too large" is tried on targets only.
        huge = 1e38 if dt == np.float32 else 1e307
        for bad in (np.nan, np.inf, -np.inf, huge):
            for which in (
                "vertices",
                "points",
                "moved points",
                "segment targets",
                "set_point_target",
                "set_segment_target",
                "translation",
            ):
                if bad == huge and which in ("vertices", "points"):
                    continue

                def f(g, dt=dt, bad=bad, which=which):
                    V, P, Q, A, B, C, D = cloud(g, n=80, k=4, s=1, dtype=dt)
                    i = int(g.integers(3))
                    badv = np.asarray(bad).astype(dt)
                    out = np.full_like(V, 7)
                    words = ["finite", "nan", "large", "range", "beyond"]
                    if which == "vertices":
                        V[i, 1] = badv
                        return refused(lambda: D_(V, points=P, segments=(A, B)), VALUE, words + ["vert"])
                    d = D_(V, points=P, segments=(A, B))
                    if which == "points":
                        P[i, 0] = badv
                        return refused(lambda: D_(V, points=P, segments=(A, B)), VALUE, words)
                    if which == "moved points":
                        Q[i, 2] = badv
                        return refused(
                            lambda: d.deform(points=Q, segments=(C, D), out=out), VALUE, words, untouched=[out]
                        )
                    if which == "segment targets":
                        C[0, 0] = badv
                        return refused(
                            lambda: d.deform(points=Q, segments=(C, D), out=out), VALUE, words, untouched=[out]
                        )
                    before = d.targets
                    if which == "set_point_target":
                        r = refused(lambda: d.set_point_target(i, [0, badv, 0]), VALUE, words)
                    elif which == "set_segment_target":
                        r = refused(lambda: d.set_segment_target(0, [0, 0, 0], [badv, 0, 0]), VALUE, words)
                    else:
                        r = refused(lambda: d.transform_handles(points=[i], translation=[badv, 0, 0]), VALUE, words)
                    same(d.targets["points"], before["points"], "targets after a refused change")
                    return r

                add("deform-nonfinite", f"{bad} in {which} {np.dtype(dt).name}", f)

    # Empty arrays and wrong counts.
    shape_cases = [
        ("no vertices", lambda V, P, Q: D_(np.zeros((0, 3)), points=P).deform(points=Q).shape == (0, 3), None),
        ("no handles", lambda V, P, Q: D_(V), (VALUE, ["handles"])),
        ("empty points, no segments", lambda V, P, Q: D_(V, points=np.zeros((0, 3))), (VALUE, ["handles"])),
        (
            "empty segments only",
            lambda V, P, Q: D_(V, segments=(np.zeros((0, 3)), np.zeros((0, 3)))),
            (VALUE, ["handles"]),
        ),
        ("one point fewer", lambda V, P, Q: D_(V, points=P).deform(points=Q[:-1]), (VALUE, ["point handles"])),
        (
            "one point more",
            lambda V, P, Q: D_(V, points=P).deform(points=np.vstack([Q, Q[:1]])),
            (VALUE, ["point handles"]),
        ),
        ("moved (k, 2)", lambda V, P, Q: D_(V, points=P).deform(points=Q[:, :2]), (VALUE, ["points", "shape"])),
        (
            "moved (k, 4)",
            lambda V, P, Q: D_(V, points=P).deform(points=np.hstack([Q, Q[:, :1]])),
            (VALUE, ["points", "shape"]),
        ),
        ("moved (3k,)", lambda V, P, Q: D_(V, points=P).deform(points=Q.ravel()), (VALUE, ["points", "shape"])),
        ("vertices (n, 2)", lambda V, P, Q: D_(V[:, :2], points=P), (VALUE, ["vertices", "shape"])),
        ("vertices 3-D", lambda V, P, Q: D_(V[None], points=P), (VALUE, ["vertices", "shape"])),
        ("segments not a pair", lambda V, P, Q: D_(V, segments=(P,)), (VALUE, ["segments"])),
        ("segments of 3", lambda V, P, Q: D_(V, segments=(P, P, P)), (VALUE, ["segments"])),
        ("segments an array", lambda V, P, Q: D_(V, segments=P), ((VALUE, TYPE), ["segments"])),
        ("segments A, B lengths", lambda V, P, Q: D_(V, segments=(P, P[:-1] + 1)), (VALUE, ["segments", "rows"])),
        (
            "moved segments count",
            lambda V, P, Q: D_(V, points=P, segments=(P[:2], P[:2] + 1)).deform(segments=(P[:1], P[:1] + 1)),
            (VALUE, ["segment"]),
        ),
        (
            "segments given, none at rest",
            lambda V, P, Q: D_(V, points=P).deform(segments=(P[:1], P[:1] + 1)),
            (VALUE, ["segment"]),
        ),
        (
            "out (n - 1, 3)",
            lambda V, P, Q: D_(V, points=P).deform(out=np.empty((len(V) - 1, 3))),
            (VALUE, ["out", "shape"]),
        ),
        (
            "out float32 for float64",
            lambda V, P, Q: D_(V, points=P).deform(out=np.empty(V.shape, np.float32)),
            (TYPE, ["out", "dtype"]),
        ),
        (
            "out F-order",
            lambda V, P, Q: D_(V, points=P).deform(out=np.asfortranarray(np.empty(V.shape))),
            (VALUE, ["out", "contiguous"]),
        ),
        (
            "out read-only",
            lambda V, P, Q: D_(V, points=P).deform(out=np.broadcast_to(np.zeros(3), V.shape)),
            (VALUE, ["out"]),
        ),
        ("out a list", lambda V, P, Q: D_(V, points=P).deform(out=V.tolist()), (TYPE, ["out"])),
        ("unknown transform", lambda V, P, Q: D_(V, points=P, transform="rigidd"), (VALUE, ["transform"])),
        ("unknown method", lambda V, P, Q: D_(V, points=P, method="qr"), (VALUE, ["method"])),
        ("unknown backend", lambda V, P, Q: D_(V, points=P, backend="gpu"), (VALUE, ["backend"])),
        ("unknown storage", lambda V, P, Q: D_(V, points=P, weight_storage="disk"), (VALUE, ["weight_storage"])),
        ("unknown segment weight", lambda V, P, Q: D_(V, points=P, segment_weight="x"), (VALUE, ["segment_weight"])),
        ("unknown centroids", lambda V, P, Q: D_(V, points=P, centroids="spline"), (VALUE, ["centroids"])),
        ("exponent 0.5", lambda V, P, Q: D_(V, points=P, exponent=0.5), (VALUE, ["exponent"])),
        ("exponent NaN", lambda V, P, Q: D_(V, points=P, exponent=float("nan")), (VALUE, ["exponent"])),
        ("exponent inf", lambda V, P, Q: D_(V, points=P, exponent=float("inf")), (VALUE, ["exponent"])),
        ("exponent a string", lambda V, P, Q: D_(V, points=P, exponent="2"), (TYPE, ["incompatible", "exponent"])),
        ("dtype int", lambda V, P, Q: D_(V, points=P, dtype=int), (TYPE, ["dtype"])),
        ("dtype bogus", lambda V, P, Q: D_(V, points=P, dtype="bogus"), (TYPE, ["type", "bogus"])),
        ("arap without faces", lambda V, P, Q: D_(V, points=P, arap_iterations=2), (VALUE, ["triangles", "faces"])),
        ("arap -1", lambda V, P, Q: D_(V, points=P, arap_iterations=-1), (VALUE, ["arap_iterations"])),
        ("positional points", lambda V, P, Q: D_(V, P), (TYPE, ["incompatible"])),
        ("unknown keyword", lambda V, P, Q: D_(V, points=P, handles=P), (TYPE, ["incompatible"])),
        (
            "on_the_fly with RBF",
            lambda V, P, Q: D_(V, points=P, centroids="rbf", weight_storage="on_the_fly"),
            (VALUE, ["on_the_fly", "rbf"]),
        ),
        (
            "set_point_target index k",
            lambda V, P, Q: D_(V, points=P).set_point_target(len(P), [0, 0, 0]),
            (INDEX, ["index"]),
        ),
        (
            "set_point_target index -1",
            lambda V, P, Q: D_(V, points=P).set_point_target(-1, [0, 0, 0]),
            (INDEX, ["index"]),
        ),
        (
            "set_point_target 2 numbers",
            lambda V, P, Q: D_(V, points=P).set_point_target(0, [0, 0]),
            (VALUE, ["target"]),
        ),
        (
            "set_segment_target no segments",
            lambda V, P, Q: D_(V, points=P).set_segment_target(0, [0] * 3, [1] * 3),
            (INDEX, ["index"]),
        ),
    ]
    for name, call, err in shape_cases:

        def f(g, call=call, err=err):
            V, P, Q, *_ = cloud(g, n=40, k=4)
            if err is None:
                if call(V, P, Q) is not True:
                    raise Wrong("unexpected result")
                return CORRECT
            return refused(lambda: call(V, P, Q), err[0], err[1])

        add("deform-errors", name, f)

    # out= holding the handles (deform copies them before it writes).
    for dt in DTYPES:

        def f(g, dt=dt):
            V, P, Q, A, B, C, D = cloud(g, n=100, k=5, s=2, dtype=dt)
            d = D_(V, points=P, segments=(A, B))
            want = d.deform(points=Q, segments=(C, D))
            X = np.zeros_like(V)
            X[:5], X[5:7], X[7:9] = Q, C, D
            d.deform(points=X[:5], segments=(X[5:7], X[7:9]), out=X)
            same(X, want, "handles inside out=")

        add("overlap", f"deform with handles inside out= {np.dtype(dt).name}", f)
