"""F1: one stray vertex far away must not tear the model (local snapping)."""
import os

import numpy as np

import mlsdeform

from .common import DATA, DTYPES, EPS, Wrong, add, same, within
from .references import mls_reference, mls_tol


D_ = mlsdeform.Deformer


def build(args):
    # ---- F1: one stray vertex far away must not tear the model (local snapping) ----
    def torn(X, V, P, Q, dt, stray, what):
        """No vertex may be put on a handle's target unless it sits on that handle at rest (within 64 eps of
        the model's own size, the snapping distance without the stray vertex); and the rest holds against
        the reference to the documented accuracy, relative to the whole scene's size (the local frame is the
        whole scene's: docs/api.md, Accuracy), which the stray vertex does enlarge."""
        size = np.linalg.norm(V.max(0) - V.min(0))
        on_target = (X[:, None, :] == Q[None].astype(X.dtype)).all(axis=2)
        near = np.linalg.norm(V[:, None].astype(np.float64) - P[None], axis=2) <= 64 * EPS[dt] * size
        bad = on_target & ~near
        if bad.any():
            raise Wrong(f"{what}: {int(bad.any(axis=1).sum())} vertices put on a handle's target from afar")
        ref, kappa, _ = mls_reference(V, P, Q)
        within(X, ref, mls_tol(len(P), kappa, EPS[dt], np.abs(stray).max() + 2), what)

    for dt in DTYPES:
        for far in (1e3, 1e4, 1e5):

            def f(g, dt=dt, far=far):
                V = g.uniform(-1, 1, (2000, 3))
                P = g.uniform(-1, 1, (4, 3))
                Q = P + g.normal(scale=0.2, size=P.shape)
                V, P, Q = (x.astype(dt) for x in (V, P, Q))
                stray = np.array([[far, 0, 0]], dt)
                X = D_(np.vstack([V, stray]), points=P).deform(points=Q)[:-1]
                torn(X, V, P, Q, dt, stray, f"with a stray vertex at x = {far:g}")

            add("snap-far-vertex", f"cloud of 2000 plus a stray vertex at {far:g} {np.dtype(dt).name}", f)

    def f(g):
        V = []
        with open(os.path.join(DATA, "human_man.obj")) as fh:
            for line in fh:
                if line.startswith("v "):
                    V.append([float(x) for x in line.split()[1:4]])
        V = np.array(V, np.float32)
        idx = np.array([1337, 3215, 3386, 411, 5906, 2445, 6618, 6786])
        P = V[idx]
        Q = P.copy()
        Q[3:6] += np.array([[0, 0.3, 0.3], [0.2, 0.6, 0.2], [-0.2, 0.6, 0.2]], np.float32)
        stray = np.array([[1e4, 0, 0]], np.float32)
        Xs = D_(np.vstack([V, stray]), points=P).deform(points=Q)[:-1]
        rest = np.setdiff1d(np.arange(len(V)), idx)
        same(Xs[idx], Q, "vertices at the handles")
        torn(Xs[rest], V[rest], P, Q, np.float32, stray, "human + v 10000 0 0")

    add("snap-far-vertex", "human with v 10000 0 0, 8 handles, float32", f)
