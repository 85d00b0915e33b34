"""Scale: the whole scene by 2^e, divided back (MLS, RBF, regions, groups)."""
import numpy as np

import mlsdeform

from .common import EPS, SCALE_ACCEPT, add, finite, within
from .references import mls_reference, mls_tol
from .scenes import cloud, exact_scaling, grid_mesh, region_ring, rigid


D_ = mlsdeform.Deformer


def build(args):
    # ---- scale: the whole scene by 2^e, divided back (MLS, RBF, regions, groups) ----
    fexps = (-120, -100, -60, -20, 20, 60, 100, 120)
    dexps = (-1000, -700, -300, 300, 700, 1000)
    for dt, exps in ((np.float32, fexps), (np.float64, dexps)):
        for e in exps:
            for variant in (
                "mls rigid",
                "mls similarity",
                "mls affine",
                "segments",
                "rbf",
                "region",
                "groups",
                "on_the_fly",
            ):

                def f(g, dt=dt, e=e, variant=variant):
                    V, P, Q, A, B, C, D = cloud(g, n=200, k=6, s=2 if variant == "segments" else 0, dtype=np.float64)
                    transform = variant.split()[1] if variant.startswith("mls") else "rigid"
                    kw = dict(transform=transform)
                    if variant == "rbf":
                        kw["centroids"] = "rbf"
                    ring = np.zeros(0, int)
                    if variant == "region":
                        V, F = grid_mesh(12, 12)
                        P = V[[0, 11, 132, 143, 66]] + 0.01
                        Q = P + g.normal(scale=0.1, size=P.shape)
                        kw["region"] = np.flatnonzero(V[:, 0] < 0.5)
                        kw["faces"] = F
                        ring = region_ring(F, kw["region"], len(V))
                    if variant == "on_the_fly":
                        kw["weight_storage"] = "on_the_fly"
                    R, t, move = rigid(g)
                    V, P, Q, A, B, C, D, t = exact_scaling(e, dt, V, P, Q, A, B, C, D, t)

                    def run(s):
                        def sc(X):
                            return np.ldexp(X, s).astype(dt)

                        seg = (sc(A), sc(B)) if variant == "segments" else None
                        d = D_(sc(V), points=sc(P), segments=seg, **kw)
                        if variant == "groups":
                            d.transform_handles(
                                points=range(len(P)),
                                rotation=R.astype(dt),
                                translation=sc(t[None])[0],
                                pivot=sc(P[:1])[0],
                            )
                            return d.deform()
                        return d.deform(points=sc(Q), segments=(sc(C), sc(D)) if seg else None)

                    X0 = run(0).astype(np.float64)
                    Xs = run(e)
                    finite(Xs, f"scene x 2^{e}")
                    # Exact MLS is scale-invariant and powers of two keep every digit: the scaled run solves
                    # the same problem, so its result divided back is held to twice the unscaled result's own
                    # bound against the reference (each carries at most one bound of error).
                    Vr, Pr, Qr = (x.astype(dt).astype(np.float64) for x in (V, P, Q))
                    if variant == "groups":
                        Qr = (Pr - Pr[0]) @ R.astype(dt).T + Pr[0] + t.astype(dt)
                    J = len(P) + len(ring) + (4 if variant == "segments" else 0)
                    args = (A, B, C, D) if variant == "segments" else ()
                    Pr, Qr = np.vstack([Pr, Vr[ring]]), np.vstack([Qr, Vr[ring]])  # the region's ring
                    rows = kw.get("region", np.arange(len(V)))
                    ref, kappa, extra = mls_reference(
                        Vr[rows], Pr, Qr, *args, transform=transform, centroids=kw.get("centroids", "mls")
                    )
                    tol = np.zeros(len(V))  # outside a region: bitwise at rest, scaled exactly
                    tol[rows] = 2 * mls_tol(J, kappa, EPS[dt], 4, extra)
                    within(np.ldexp(Xs.astype(np.float64), -e), X0, tol, f"scene x 2^{e}, divided back")

                add("scale", f"{variant} x 2^{e} {np.dtype(dt).name}", f, accept=SCALE_ACCEPT)
