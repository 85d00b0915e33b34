"""Groups of handles (transform_handles), and numpy integers as indices."""
import numpy as np

import mlsdeform

from .common import DTYPES, EPS, INDEX, TYPE, VALUE, add, refused, same, within
from .references import mls_reference, mls_tol
from .scenes import cloud, rigid


D_ = mlsdeform.Deformer


def build(args):
    # ---- groups (transform_handles) ----
    for dt in DTYPES:
        for members in ("all", "some", "segments only", "one point"):

            def f(g, dt=dt, members=members):
                V, P, Q, A, B, C, D = cloud(g, n=200, k=5, s=2, dtype=dt)
                d = D_(V, points=P, segments=(A, B))
                R, t, _ = rigid(g)
                c = g.uniform(-1, 1, 3)
                pts = {"all": range(5), "some": [1, 3], "segments only": [], "one point": [np.int64(2)]}[members]
                sgs = {"all": [0, 1], "some": [1], "segments only": [0, 1], "one point": []}[members]
                before = d.targets
                d.transform_handles(points=pts, segments=sgs, rotation=R, translation=t, pivot=c)
                after = d.targets
                move = (
                    lambda X: (np.asarray(X, np.float64) - c.astype(dt)) @ R.astype(dt).T.astype(np.float64)
                    + c.astype(dt)
                    + t.astype(dt)
                )
                # Each image coordinate: 3 products and 5 sums of terms below 4 in magnitude: 8 x 4 eps of
                # the exact value, for the library (in T) and for this float64 evaluation of the same rounded
                # R, t, c: 2 x 32 eps.
                tol = 64 * EPS[dt] * 2
                pts = [int(i) for i in pts]
                others = np.setdiff1d(np.arange(5), pts)
                within(after["points"][pts], move(P[pts]), tol, "moved points")
                same(after["points"][others], before["points"][others], "points not in the group")
                for k in range(2):
                    within(after["segments"][k][sgs], move([A, B][k][sgs]), tol, "moved segments")
                same(
                    d.deform(), d.deform(points=after["points"], segments=after["segments"]), "deform() after the group"
                )
                if members == "all":
                    ref = mls_reference(V, P, move(P), A, B, move(A), move(B))
                    within(d.deform(), move(V), mls_tol(9, ref[1], EPS[dt], 4) + 2 * tol, "all handles rigidly")

            add("groups", f"{members} {np.dtype(dt).name}", f)
    group_errors = [
        ("reflection", lambda d: d.transform_handles(points=[0], rotation=-np.eye(3)), VALUE, ["reflection"]),
        (
            "not orthonormal",
            lambda d: d.transform_handles(points=[0], rotation=np.eye(3) * (1 + 1e-9)),
            VALUE,
            ["orthonormal", "not a rotation"],
        ),
        (
            "NaN rotation",
            lambda d: d.transform_handles(points=[0], rotation=np.full((3, 3), np.nan)),
            VALUE,
            ["finite", "nan"],
        ),
        ("rotation (2, 2)", lambda d: d.transform_handles(points=[0], rotation=np.eye(2)), VALUE, ["rotation"]),
        ("rotation complex", lambda d: d.transform_handles(points=[0], rotation=np.eye(3) + 0j), TYPE, ["rotation"]),
        ("point index out of range", lambda d: d.transform_handles(points=[0, 9]), INDEX, ["index 9"]),
        ("segment index out of range", lambda d: d.transform_handles(segments=[2]), INDEX, ["index 2"]),
        ("negative index", lambda d: d.transform_handles(points=[-1]), INDEX, ["index -1"]),
        ("index 0.5", lambda d: d.transform_handles(points=[0.5]), VALUE, ["points", "0.5"]),
        ("segment index 1.25", lambda d: d.transform_handles(segments=[1.25]), VALUE, ["segments", "1.25"]),
        ("bool mask", lambda d: d.transform_handles(points=[True, False]), TYPE, ["points"]),
        ("2-D indices", lambda d: d.transform_handles(points=[[0]]), VALUE, ["points", "1-D"]),
        ("pivot 2 numbers", lambda d: d.transform_handles(points=[0], pivot=[0, 0]), VALUE, ["pivot"]),
        (
            "translation inf",
            lambda d: d.transform_handles(points=[0], translation=[np.inf, 0, 0]),
            VALUE,
            ["finite", "translation"],
        ),
        (
            "image too large",
            lambda d: d.transform_handles(points=[0], translation=[1e308, 0, 0]),
            VALUE,
            ["finite", "large", "beyond", "max"],
        ),
    ]
    for name, call, exc, words in group_errors:

        def f(g, call=call, exc=exc, words=words):
            V, P, Q, A, B, *_ = cloud(g, n=50, k=4, s=2)
            d = D_(V, points=P, segments=(A, B))
            before = d.targets
            r = refused(lambda: call(d), exc, words)
            same(d.targets["points"], before["points"], "targets after a refused group")
            same(d.targets["segments"][0], before["segments"][0], "segment targets after a refused group")
            return r

        add("groups-errors", name, f)
    for name, call in [
        ("set_point_target 1.0", lambda d: d.set_point_target(1.0, [0, 0, 0])),
        ("set_point_target np.float64(1)", lambda d: d.set_point_target(np.float64(1), [0, 0, 0])),
        ("set_point_target '1'", lambda d: d.set_point_target("1", [0, 0, 0])),
        ("set_segment_target 0.0", lambda d: d.set_segment_target(0.0, [0] * 3, [1] * 3)),
        ("precompute_budget_bytes 1e6", lambda d: D_(np.eye(3), points=np.eye(3), precompute_budget_bytes=1e6)),
        ("precompute_budget_bytes -1", lambda d: D_(np.eye(3), points=np.eye(3), precompute_budget_bytes=-1)),
    ]:

        def f(g, call=call):
            V, P, Q, A, B, *_ = cloud(g, n=50, k=4, s=1)
            d = D_(V, points=P, segments=(A, B))
            before = d.targets
            r = refused(lambda: call(d), TYPE, ["incompatible"])
            same(d.targets["points"], before["points"], "targets after a refused call")
            return r

        add("integers", name, f)

    def f(g):
        V, P, Q, *_ = cloud(g, n=50, k=4)
        d = D_(V, points=P)
        for i in (np.int8(1), np.uint64(2), True):
            d.set_point_target(i, Q[int(i)])
        want = P.copy()
        want[[1, 2]] = Q[[1, 2]]
        same(d.targets["points"], want, "integer-like indices")

    add("integers", "set_point_target with numpy integers and True", f)
