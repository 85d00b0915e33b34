"""The deformer against the direct numpy MLS: transforms, storages, invariants, few and coincident handles;
segments (build_segments)."""
import numpy as np

import mlsdeform

from .common import DTYPES, EPS, METHODS, VALUE, Wrong, add, refused, same, within
from .references import check_mls, mls_reference, mls_tol
from .scenes import cloud, rigid


D_ = mlsdeform.Deformer


def build(args):
    # ---- the deformer against the direct numpy MLS ----
    storages = ("automatic", "precomputed", "on_the_fly", "precomputed_weights")
    combos = []
    for dt in DTYPES:
        for transform in ("rigid", "similarity", "affine"):
            for s in (0, 2):
                for u in (1.0, 2.0, 3.5):
                    combos.append((dt, transform, s, u))
    for i, (dt, transform, s, u) in enumerate(combos):
        for backend in ("simd", "scalar"):

            def f(g, dt=dt, transform=transform, s=s, u=u, backend=backend, i=i):
                V, P, Q, A, B, C, D = cloud(g, n=400, k=6, s=s, dtype=dt)
                storage = storages[i % 4] if (s == 0 and transform != "affine") else storages[i % 2]
                method = METHODS[i % 5]
                seg = (A, B) if s else None
                d = D_(
                    V,
                    points=P,
                    segments=seg,
                    transform=transform,
                    exponent=u,
                    backend=backend,
                    weight_storage=storage,
                    method=method,
                )
                X = d.deform(points=Q, segments=(C, D) if s else None)
                if X.dtype != dt:
                    raise Wrong(f"dtype {X.dtype}")
                check_mls(X, V, P, Q, dt, *((A, B, C, D) if s else ()), transform=transform, u=u)

            add("deform", f"{transform} u={u} segments={s} {np.dtype(dt).name} {backend}", f)

    # Invariants: rest pose, rigid motion of every handle (MLS reproduces it), stateful targets.
    for dt in DTYPES:
        for transform in ("rigid", "similarity", "affine"):
            for sw in ("paper_constant", "exact_integral"):

                def f(g, dt=dt, transform=transform, sw=sw):
                    V, P, Q, A, B, C, D = cloud(g, n=300, k=5, s=2, dtype=dt)
                    d = D_(V, points=P, segments=(A, B), transform=transform, segment_weight=sw)
                    X0 = d.deform()
                    R, t, move = rigid(g)
                    X1 = d.deform(points=move(P).astype(dt), segments=(move(A).astype(dt), move(B).astype(dt)))
                    # The exact weights lie between the constant ones' extremes along the segment, so the
                    # conditioning of the constant-weight fit bounds theirs within the ratio of the extreme
                    # weights: the reference's kappa times that ratio (at most 10 here, for u = 2).
                    _, kappa, _ = mls_reference(V, P, P, A, B, A, B, transform)
                    tol = mls_tol(len(P) + 4, kappa * (10 if sw == "exact_integral" else 1), EPS[dt], 4)
                    within(X0, V.astype(np.float64), tol, "rest pose")
                    within(X1, move(V), tol, "rigid motion of every handle")

                add("deform-invariants", f"rest and rigid motion {transform} {sw} {np.dtype(dt).name}", f)

        def f(g, dt=dt):
            V, P, Q, A, B, C, D = cloud(g, n=200, k=5, s=2, dtype=dt)
            d = D_(V, points=P, segments=(A, B))
            for i in range(5):
                d.set_point_target(i, Q[i])
            d.set_segment_target(0, C[0], D[0])
            d.set_segment_target(np.int64(1), C[1], D[1])
            same(d.deform(), d.deform(points=Q, segments=(C, D)), "set targets vs deform(points=...)")
            same(d.targets["points"], Q, "targets")
            check_mls(d.deform(), V, P, Q, dt, A, B, C, D)

        add("deform-invariants", f"stateful targets {np.dtype(dt).name}", f)

    # Few, duplicate and coincident handles.
    for dt in DTYPES:

        def f(g, dt=dt):
            V, P, Q, *_ = cloud(g, n=100, k=1, dtype=dt)
            X = D_(V, points=P).deform(points=Q)
            within(X, V.astype(np.float64) + (Q[0] - P[0]), 16 * EPS[dt] * 4, "one handle: a translation")

        add("deform-handles", f"one handle {np.dtype(dt).name}", f)

        def f(g, dt=dt):
            V, P, Q, *_ = cloud(g, n=200, k=4, dtype=dt)
            P2, Q2 = np.vstack([P, P[:2]]), np.vstack([Q, Q[:2]])
            check_mls(D_(V, points=P2).deform(points=Q2), V, P2, Q2, dt, what="duplicate handles")

        add("deform-handles", f"duplicate handles {np.dtype(dt).name}", f)

        def f(g, dt=dt):
            V, P, Q, *_ = cloud(g, n=200, k=6, dtype=dt)
            idx = g.choice(len(V), 6, replace=False)
            P = V[idx].copy()
            X = D_(V, points=P).deform(points=Q)
            same(X[idx], Q, "vertices at handles land on their targets")
            rest = np.setdiff1d(np.arange(len(V)), idx)
            check_mls(X[rest], V[rest], P, Q, dt, what="other vertices")

        add("deform-handles", f"handles at vertices {np.dtype(dt).name}", f)

        def f(g, dt=dt):
            V, P, Q, *_ = cloud(g, n=100, k=4, dtype=dt)
            P[:, 2] = 0
            return refused(lambda: D_(V, points=P, transform="affine"), VALUE, ["coplanar", "collinear", "span"])

        add("deform-handles", f"coplanar handles affine {np.dtype(dt).name}", f)

        def f(g, dt=dt):
            V, P, Q, A, B, C, D = cloud(g, n=50, k=3, s=1, dtype=dt)
            return refused(lambda: D_(V, points=P, segments=(A, A.copy())), VALUE, ["zero-length", "segment"])

        add("deform-handles", f"zero-length segment {np.dtype(dt).name}", f)


def build_segments(args):
    # ---- segments against numpy ----
    for dt in DTYPES:
        for s in (1, 3, 8):
            for k in (0, 3):

                def f(g, dt=dt, s=s, k=k):
                    V, P, Q, A, B, C, D = cloud(g, n=250, k=max(k, 1), s=s, dtype=dt)
                    P, Q = P[:k], Q[:k]
                    d = D_(V, points=P if k else None, segments=(A, B))
                    X = d.deform(points=Q if k else None, segments=(C, D))
                    check_mls(X, V, P, Q, dt, A, B, C, D, what="segment handles")
                    for i in range(s):
                        d.set_segment_target(i, A[i], B[i])
                    same(
                        d.deform(points=Q if k else None),
                        d.deform(points=Q if k else None, segments=(A, B)),
                        "set_segment_target",
                    )

                add("segments", f"{s} segments, {k} points {np.dtype(dt).name}", f)
