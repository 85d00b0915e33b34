"""RBF centroids against numpy's RBF solve; regions against the MLS with the ring as fixed handles
(docs/api.md, Region of interest)."""
import numpy as np

import mlsdeform

from .common import BadError, CLEAR, DTYPES, EPS, TYPE, VALUE, add, refused, same, within, words_in
from .references import check_mls, mls_reference, mls_tol
from .scenes import cloud, grid_mesh, region_ring, rigid


D_ = mlsdeform.Deformer


def build(args):
    # ---- RBF centroids against numpy's RBF solve ----
    for dt in DTYPES:
        for transform in ("rigid", "similarity", "affine"):
            for s in (0, 1):

                def f(g, dt=dt, transform=transform, s=s):
                    V, P, Q, A, B, C, D = cloud(g, n=300, k=7, s=s, dtype=dt)
                    seg = (A, B) if s else None
                    X = D_(V, points=P, segments=seg, transform=transform, centroids="rbf").deform(
                        points=Q, segments=(C, D) if s else None
                    )
                    check_mls(
                        X,
                        V,
                        P,
                        Q,
                        dt,
                        *((A, B, C, D) if s else ()),
                        transform=transform,
                        centroids="rbf",
                        what="RBF centroids",
                    )

                add("rbf", f"{transform} segments={s} {np.dtype(dt).name}", f)
        for pose in ("rest", "rigid", "affine handles, affine transform"):

            def f(g, dt=dt, pose=pose):
                V, P, Q, *_ = cloud(g, n=300, k=8, dtype=dt)
                if pose == "rest":
                    Q, want = P, V.astype(np.float64)
                elif pose == "rigid":
                    R, t, move = rigid(g)
                    Q, want = move(P).astype(dt), move(V)
                else:
                    Mx = np.eye(3) + g.normal(scale=0.2, size=(3, 3))
                    Q, want = (P.astype(np.float64) @ Mx.T + 0.3).astype(dt), V.astype(np.float64) @ Mx.T + 0.3
                transform = "affine" if pose.startswith("affine") else "rigid"
                X = D_(V, points=P, centroids="rbf", transform=transform).deform(points=Q)
                ref, kappa, extra = mls_reference(V, P, Q, transform=transform, centroids="rbf")
                within(X, want, mls_tol(len(P), kappa, EPS[dt], 4, extra), f"RBF {pose} reproduced")

            add("rbf", f"{pose} reproduced {np.dtype(dt).name}", f)

        def f(g, dt=dt):
            V, P, Q, *_ = cloud(g, n=50, k=5, dtype=dt)
            P = np.vstack([P, P[:1] + dt(1e-9)])
            Q = np.vstack([Q, Q[:1]])
            try:
                X = D_(V, points=P, centroids="rbf").deform(points=Q)
            except ValueError as e:
                if words_in(str(e), ["close", "condition", "rbf", "centroid"]):
                    return CLEAR
                raise BadError(str(e))
            check_mls(X, V, P, Q, dt, centroids="rbf", what="nearly coincident RBF centres")

        add("rbf", f"two handles 1e-9 apart {np.dtype(dt).name}", f)

    # ---- regions against the MLS with the ring as fixed handles (docs/api.md, Region of interest) ----
    for dt in DTYPES:
        for kind in ("half", "random third", "one vertex", "all"):

            def f(g, dt=dt, kind=kind):
                V, F = grid_mesh(12, 12, dt)
                n = len(V)
                region = {
                    "half": np.flatnonzero(V[:, 0] < 0.5),
                    "random third": np.sort(g.choice(n, n // 3, replace=False)),
                    "one vertex": np.array([50]),
                    "all": np.arange(n),
                }[kind]
                handles = np.array([0, 11, 132, 143, 66])
                P = V[handles] + dt(0.01)
                Q = P + g.normal(scale=0.1, size=P.shape).astype(dt)
                X = D_(V, points=P, faces=F, region=region).deform(points=Q)
                outside = np.setdiff1d(np.arange(n), region)
                same(X[outside], V[outside], "outside the region: bitwise at rest")
                ring = region_ring(F, region, n)
                P2 = np.vstack([P, V[ring]])
                Q2 = np.vstack([Q, V[ring]])
                check_mls(X[region], V[region], P2, Q2, dt, what="region vs MLS with its ring held")

            add("region", f"{kind} {np.dtype(dt).name}", f)
    region_errors = [
        ("region 1.5", lambda V, P: D_(V, points=P, region=[0, 1.5]), VALUE, ["region", "1.5"]),
        ("region NaN", lambda V, P: D_(V, points=P, region=[0, np.nan]), VALUE, ["region", "nan"]),
        ("region bool mask", lambda V, P: D_(V, points=P, region=V[:, 0] > 0), TYPE, ["region", "flatnonzero"]),
        ("region empty", lambda V, P: D_(V, points=P, region=[]), VALUE, ["region", "no vertices"]),
        ("region out of range", lambda V, P: D_(V, points=P, region=[0, len(V)]), VALUE, ["region", "vertex"]),
        ("region negative", lambda V, P: D_(V, points=P, region=[-1]), VALUE, ["region", "vertex", "negative"]),
        ("region twice", lambda V, P: D_(V, points=P, region=[3, 3]), VALUE, ["region", "twice", "once"]),
        ("region 2-D", lambda V, P: D_(V, points=P, region=[[0, 1]]), VALUE, ["region", "1-D"]),
        ("region strings", lambda V, P: D_(V, points=P, region=["0"]), TYPE, ["region"]),
    ]
    for name, call, exc, words in region_errors:

        def f(g, call=call, exc=exc, words=words):
            V, P, *_ = cloud(g, n=50, k=4)
            return refused(lambda: call(V, P), exc, words)

        add("region-errors", name, f)
    for kind in ("float64", "float32", "uint8", "list of floats", "numpy int32 scalars"):

        def f(g, kind=kind):
            V, P, Q, *_ = cloud(g, n=60, k=4)
            region = np.arange(0, 60, 3)
            conv = {
                "float64": region.astype(np.float64),
                "float32": region.astype(np.float32),
                "uint8": region.astype(np.uint8),
                "list of floats": [float(i) for i in region],
                "numpy int32 scalars": [np.int32(i) for i in region],
            }[kind]
            same(
                D_(V, points=P, region=conv).deform(points=Q),
                D_(V, points=P, region=region).deform(points=Q),
                f"region as {kind}",
            )

        add("integers", f"region as {kind} (integral values)", f)
