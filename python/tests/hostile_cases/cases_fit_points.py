"""fit_points against numpy (weighted Kabsch / Umeyama), its scale range and its refusals."""
import numpy as np

import mlsdeform

from .common import (
    BadError,
    CLEAR,
    DTYPES,
    EPS,
    METHODS,
    SCALE_ACCEPT,
    SCALE_WORDS,
    TYPE,
    VALUE,
    Wrong,
    add,
    refused,
    within,
    words_in,
)
from .references import kabsch, rotation_tol
from .scenes import exact_scaling, rigid


def build(args):
    # ---- fit_points against numpy (weighted Kabsch / Umeyama) ----
    def fit_points_reference(P, Q, w, transform):
        w = np.ones(len(P)) if w is None else np.asarray(w, np.float64)
        pc, qc = w @ P / w.sum(), w @ Q / w.sum()
        H = np.einsum("n,na,nb->ab", w, Q - qc, P - pc)
        R, kappa = kabsch(H[None])
        s = np.trace(R[0].T @ H) / np.einsum("n,na,na->", w, P - pc, P - pc) if transform == "similarity" else 1.0
        return R[0], qc - s * R[0] @ pc, s, kappa[0]

    for dt in DTYPES:
        for transform in ("rigid", "similarity"):
            for method in METHODS:
                for weights in ("none", "random", "some zero"):

                    def f(g, dt=dt, transform=transform, method=method, weights=weights):
                        n = int(g.integers(3, 40))
                        P = g.normal(size=(n, 3))
                        R0, t0, move = rigid(g)
                        Q = move(P) * (g.uniform(0.5, 2) if transform == "similarity" else 1) + g.normal(
                            scale=0.01, size=P.shape
                        )
                        w = None if weights == "none" else g.uniform(0.1, 2, n)
                        if weights == "some zero":
                            w[: n // 3] = 0
                        P, Q = P.astype(dt), Q.astype(dt)
                        w = None if w is None else w.astype(dt)
                        r = mlsdeform.fit_points(P, Q, w, transform=transform, method=method)
                        R, t, s, kappa = fit_points_reference(P.astype(np.float64), Q.astype(np.float64), w, transform)
                        eps = EPS[dt]
                        tol = rotation_tol(kappa, eps)
                        if np.linalg.norm(r[0] - R) > tol:
                            raise Wrong(f"R off by {np.linalg.norm(r[0] - R):.3g} (bound {tol:.3g})")
                        # t = q* - s R p*: the rotation's error times |p*| plus the sums' (n + 16) eps.
                        scale = np.abs(P).max() + np.abs(Q).max()
                        if np.linalg.norm(r[1] - t) > (tol * 2 + (n + 16) * eps) * scale * 4:
                            raise Wrong(f"t off by {np.linalg.norm(r[1] - t):.3g}")
                        if transform == "similarity" and abs(r[2] - s) > (tol + (n + 16) * eps) * 4 * s:
                            raise Wrong(f"s = {r[2]!r}, expected {s!r}")

                    add("fit_points", f"{transform} {method} w={weights} {np.dtype(dt).name}", f)
    for dt, exps in ((np.float32, (-120, -60, 60, 120)), (np.float64, (-1000, -500, 200, 500, 1000))):
        for e in exps:

            def f(g, dt=dt, e=e):
                P = g.normal(size=(10, 3))
                _, _, move = rigid(g)
                P, Q = exact_scaling(e, dt, P, move(P))
                R0, t0 = mlsdeform.fit_points(P.astype(dt), Q.astype(dt))
                R1, t1 = mlsdeform.fit_points(np.ldexp(P, e).astype(dt), np.ldexp(Q, e).astype(dt))
                within(R1, R0, 64 * EPS[dt] * 8, f"R at 2^{e}")
                within(np.ldexp(t1.astype(np.float64), -e), t0, 64 * EPS[dt] * 8 * 4, f"t / 2^{e}")

            add("scale-fit_points", f"fit_points scene x 2^{e} {np.dtype(dt).name}", f, accept=SCALE_ACCEPT)

    def f(g):
        P = g.normal(size=(10, 3))
        try:
            mlsdeform.fit_points(P * 1e200, P * 1e200 + 1e200)
        except ValueError as e:
            if "nan or infinite" in str(e).lower():
                raise BadError(f"finite input called NaN or infinite: {e}")
            if not words_in(str(e), SCALE_WORDS):
                raise BadError(str(e))
            return CLEAR

    add("fit_points-huge", "fit_points at 1e200 names no NaN for finite input", f)
    fp_errors = [
        ("negative weight", lambda P: mlsdeform.fit_points(P, P, -np.ones(len(P))), VALUE, ["weight"]),
        ("4 weights for 5 points", lambda P: mlsdeform.fit_points(P, P, np.ones(4)), VALUE, ["weight"]),
        ("2-D weights", lambda P: mlsdeform.fit_points(P, P, np.ones((5, 1))), VALUE, ["w"]),
        (
            "NaN weight",
            lambda P: mlsdeform.fit_points(P, P, np.array([1, 1, np.nan, 1, 1.0])),
            VALUE,
            ["weight", "nan", "finite"],
        ),
        ("all weights zero", lambda P: mlsdeform.fit_points(P, P, np.zeros(5)), VALUE, ["weight"]),
        ("P and Q lengths", lambda P: mlsdeform.fit_points(P, P[:4]), VALUE, ["points", "p has"]),
        ("NaN in P", lambda P: mlsdeform.fit_points(np.where(P > 0.5, np.nan, P), P), VALUE, ["nan", "finite"]),
        ("inf in Q", lambda P: mlsdeform.fit_points(P, np.where(P > 0.5, np.inf, P)), VALUE, ["nan", "finite"]),
        ("affine", lambda P: mlsdeform.fit_points(P, P, transform="affine"), VALUE, ["transform"]),
        ("shape (n, 2)", lambda P: mlsdeform.fit_points(P[:, :2], P[:, :2]), VALUE, ["P", "shape"]),
        ("complex", lambda P: mlsdeform.fit_points(P + 1j, P), TYPE, ["P", "real"]),
        (
            "no points",
            lambda P: mlsdeform.fit_points(np.zeros((0, 3)), np.zeros((0, 3))),
            VALUE,
            ["point", "empty", "no "],
        ),
        ("fit_rotation shape", lambda P: mlsdeform.fit_rotation(np.zeros((1, 3, 3))), VALUE, ["H", "shape"]),
        ("fit_rotation NaN", lambda P: mlsdeform.fit_rotation(np.full((3, 3), np.nan)), VALUE, ["nan", "finite"]),
    ]
    for name, call, exc, words in fp_errors:

        def f(g, call=call, exc=exc, words=words):
            P = g.normal(size=(5, 3))
            return refused(lambda: call(P), exc, words)

        add("fit_points-errors", name, f)
