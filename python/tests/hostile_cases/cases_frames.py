"""Frames (deform(..., quaternions=, rotations=, scales=, linear=)) under an exact rigid, similarity or affine
motion of every handle, in every weight storage, float and double: away from handles, on point and segment
handles (ends and interior), beside them at 10^-k (k = 1..12) of the handles' spacing, far from them, and with
an outlier vertex at 10^3..10^6 diagonals. Every vertex must get the motion's position and frame
(motions.check_motion: the tolerance derived per vertex from the conditioning computed in float64)."""
import numpy as np

import mlsdeform

from .common import DTYPES, EPS, VALUE, Skip, Wrong, add, refused, same, within
from .motions import check_motion, conditioning, effective_kappa, frame_arrays, motion, moved, rotation_bound

D_ = mlsdeform.Deformer
STORAGES = ("automatic", "precomputed", "on_the_fly", "precomputed_weights")
TRANSFORMS = ("rigid", "similarity", "affine")
SEGMENT_WEIGHTS = ("paper_constant", "exact_integral")


def spread(g, k, lo=0.45):
    """k points in [-1, 1]^3, pairwise at least lo apart (well-spread handles)."""
    while True:
        P = g.uniform(-1, 1, (k, 3))
        d = np.linalg.norm(P[:, None] - P[None], axis=2) + np.eye(k) * 9
        if d.min() >= lo:
            return P


def handles(g, kind):
    """(points, segment ends a, b): 'points' 5 points; 'segments' 3 segments; 'mixed' 4 points, 2 segments.
    Segments of length 0.5 to 1.2, every pair of handles at least 0.3 apart (sampled)."""
    npts, nseg = {"points": (5, 0), "segments": (0, 3), "mixed": (4, 2)}[kind]
    while True:
        P = spread(g, npts) if npts else np.zeros((0, 3))
        a = g.uniform(-1, 1, (nseg, 3))
        e = g.normal(size=(nseg, 3))
        e *= (g.uniform(0.5, 1.2, nseg) / np.linalg.norm(e, axis=1))[:, None]
        b = a + e
        clouds = [p[None] for p in P] + [a[j] + np.linspace(0, 1, 9)[:, None] * e[j] for j in range(nseg)]
        ok = all(
            np.linalg.norm(clouds[i][:, None] - clouds[j][None], axis=2).min() >= 0.3
            for i in range(len(clouds))
            for j in range(i)
        )
        if ok:
            return P, a, b, clouds


def spacing(clouds):
    return min(
        np.linalg.norm(clouds[i][:, None] - clouds[j][None], axis=2).min() for i in range(len(clouds)) for j in range(i)
    )


def unit(g, n=1):
    x = g.normal(size=(n, 3))
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def run_session(V, P, a, b, dt, storage, transform, sw, Q, c, d, extra=None):
    kw = dict(transform=transform, weight_storage=storage, segment_weight=sw)
    if transform == "affine":
        kw["affine_frames"] = True
    kw.update(extra or {})
    seg = (a, b) if len(a) else None
    ses = D_(V, points=P if len(P) else None, segments=seg, **kw)
    fr = frame_arrays(len(V), dt, transform)
    X = ses.deform(points=Q if len(P) else None, segments=(c, d) if len(a) else None, **fr)
    plain = ses.deform(points=Q if len(P) else None, segments=(c, d) if len(a) else None)
    same(X, plain, "positions with frames against without")
    return X, fr


def frames_case(g, dt, storage, transform, kind, sw, placement, param=None, extra=None):
    P, a, b, clouds = handles(g, kind)
    h = spacing(clouds)
    gen = g.uniform(-1.3, 1.3, (16, 3))
    if placement == "generic":
        V = g.uniform(-1.3, 1.3, (60, 3))
    elif placement in ("on", "near"):
        sites, dirs = [], []
        for p in P:
            sites.append(p)
            dirs.append(unit(g)[0])
        for j in range(len(a)):
            e = b[j] - a[j]
            perp = np.cross(e, unit(g)[0])
            perp /= np.linalg.norm(perp)
            for t in (0.0, 1.0, 0.4, 0.77):
                sites.append(a[j] + t * e)
                # beside an end: outward along the segment or across it; beside the interior: across it
                dirs.append(perp if 0 < t < 1 else (unit(g)[0] if g.uniform() < 0.5 else (2 * t - 1) * e))
        sites = np.array(sites)
        dirs = np.array([x / np.linalg.norm(x) for x in dirs])
        delta = 0.0 if placement == "on" else 10.0 ** (-param) * h
        V = np.vstack([gen, sites + delta * dirs])
    elif placement == "far":
        centre = np.mean(np.vstack(clouds), axis=0)
        V = np.vstack([gen, centre + param * h * unit(g, 12)])
    V = np.ascontiguousarray(V.astype(dt))
    # The handles are given exactly at their vertices' values (rounded to T once, as the vertices).
    P = np.ascontiguousarray(P.astype(dt))
    a = np.ascontiguousarray(a.astype(dt))
    b = np.ascontiguousarray(b.astype(dt))
    if placement == "on":
        # The interior sites were rounded to T: on the segment within its rounding, as a user's would be.
        n0 = len(gen)
        V[n0 : n0 + len(P)] = P
        for j in range(len(a)):
            V[n0 + len(P) + 4 * j] = a[j]
            V[n0 + len(P) + 4 * j + 1] = b[j]
    A, R, s, t = motion(g, transform)
    Q, c, d = moved(P, A, t, dt), moved(a, A, t, dt), moved(b, A, t, dt)
    X, fr = run_session(V, P, a, b, dt, storage, transform, sw, Q, c, d, extra)
    if len(P):
        # A vertex on a point handle lands on its target bit for bit (the map interpolates it: docs/api.md).
        hit = (V[:, None, :] == P[None]).all(axis=2)
        rows, cols = np.nonzero(hit)
        same(X[rows], Q[cols], "vertices on point handles: their targets")
    kf, ko, arm = conditioning(V, P, a, b, sw, 2.0, transform)
    exactly_on = ~np.isfinite(kf)
    kappa = effective_kappa(kf, ko, dt, exactly_on)
    if not np.all(np.isfinite(kappa)):
        raise Wrong("scene without a defined limit (test scene error)")
    J = len(P) + 2 * len(a)
    check_motion(X, fr, V, A, R, s, t, transform, dt, kappa, arm, J, f"{placement} {param}")


def outlier_case(g, dt, storage, transform, far, kind):
    """Model vertices (a cloud in [-1, 1]^3 with 4 point handles and a segment) with and without one stray
    vertex at `far` diagonals: under an exact motion every model vertex gets the motion to the bound the
    model's own scale gives (docs/api.md: an outlier no longer coarsens the others), and the two runs agree to
    twice that; the stray vertex gets the motion to its own scale's bound."""
    P, a, b, clouds = handles(g, kind)
    Vm = g.uniform(-1, 1, (120, 3))
    diag = np.linalg.norm(Vm.max(0) - Vm.min(0))
    stray = unit(g)[0] * far * diag
    Vm, P, a, b = (np.ascontiguousarray(x.astype(dt)) for x in (Vm, P, a, b))
    V = np.ascontiguousarray(np.vstack([Vm, stray[None].astype(dt)]))
    A, R, s, t = motion(g, transform)
    Q, c, d = moved(P, A, t, dt), moved(a, A, t, dt), moved(b, A, t, dt)
    X, fr = run_session(V, P, a, b, dt, storage, transform, "paper_constant", Q, c, d)
    X0, fr0 = run_session(Vm, P, a, b, dt, storage, transform, "paper_constant", Q, c, d)
    kf, ko, arm = conditioning(V, P, a, b, "paper_constant", 2.0, transform)
    kappa = effective_kappa(kf, ko, dt, ~np.isfinite(kf))
    J = len(P) + 2 * len(a)
    m = len(Vm)
    sub = {k: v[:m] for k, v in fr.items()}
    check_motion(X[:m], sub, Vm, A, R, s, t, transform, dt, kappa[:m], arm[:m], J, "model beside an outlier")
    last = {k: v[m:] for k, v in fr.items()}
    check_motion(X[m:], last, V[m:], A, R, s, t, transform, dt, kappa[m:], arm[m:], J, "the outlier itself")
    # With and without the outlier: each run is within one bound of the exact motion, so within two of each
    # other (positions at the model's scale: 16 (J + 16) eps |model|, plus the frame's error on its arm).
    tolR = rotation_bound(kappa[:m], EPS[dt])
    nA = np.linalg.norm(A, 2)
    scale = max(np.abs(Vm.astype(np.float64)).max(), np.abs(Vm.astype(np.float64) @ A.T + t).max(), 1.0)
    within(X[:m], X0.astype(np.float64), 2 * (16 * (J + 16) * EPS[dt] * scale + tolR * nA * arm[:m]), "with/without")


def build(args):
    for dt in DTYPES:
        for storage in STORAGES:
            # on_the_fly and precomputed_weights take point handles with rigid or similarity fits only
            # (refused otherwise: the refusal cases below).
            full = storage in ("automatic", "precomputed")
            for transform in TRANSFORMS if full else TRANSFORMS[:2]:
                name = f"{transform} {storage} {np.dtype(dt).name}"
                pt = (("points", "paper_constant"),)
                mixed = tuple(("mixed", w) for w in SEGMENT_WEIGHTS) if full else ()
                segs = tuple((k, w) for k in ("segments", "mixed") for w in SEGMENT_WEIGHTS) if full else ()
                for kind, sw in pt + mixed:

                    def f(g, dt=dt, storage=storage, transform=transform, kind=kind, sw=sw):
                        frames_case(g, dt, storage, transform, kind, sw, "generic")

                    add("frames-generic", f"{name} {kind} {sw}", f)
                for kind, sw in pt + segs:

                    def f(g, dt=dt, storage=storage, transform=transform, kind=kind, sw=sw):
                        frames_case(g, dt, storage, transform, kind, sw, "on")

                    add("frames-on", f"on handles {name} {kind} {sw}", f)
                for kind, sw in mixed or pt:
                    for k in range(1, 13):

                        def f(g, dt=dt, storage=storage, transform=transform, kind=kind, sw=sw, k=k):
                            frames_case(g, dt, storage, transform, kind, sw, "near", k)

                        add("frames-near", f"1e-{k} x spacing {name} {kind} {sw}", f)
                for (kind, sw), far in zip(mixed or pt + pt, (10.0, 1000.0)):

                    def f(g, dt=dt, storage=storage, transform=transform, kind=kind, sw=sw, far=far):
                        frames_case(g, dt, storage, transform, kind, sw, "far", far)

                    add("frames-far", f"{far:g} x spacing {name} {kind} {sw}", f)
                for far in (1e3, 1e4, 1e5, 1e6):

                    def f(
                        g, dt=dt, storage=storage, transform=transform, far=far, kind=("mixed" if full else "points")
                    ):
                        outlier_case(g, dt, storage, transform, far, kind)

                    add("frames-outlier", f"stray vertex at {far:g} diagonals {name}", f)
            if not full:
                for what in ("affine", "segments"):

                    def f(g, dt=dt, storage=storage, what=what):
                        P, a, b, _ = handles(g, "mixed")
                        V = g.uniform(-1, 1, (20, 3)).astype(dt)
                        kw = dict(weight_storage=storage)
                        if what == "affine":
                            kw["transform"] = "affine"
                        else:
                            kw["segments"] = (a.astype(dt), b.astype(dt))
                        return refused(lambda: D_(V, points=P.astype(dt), **kw), VALUE, [storage])

                    add("frames-storage", f"{storage} with {what} {np.dtype(dt).name}: refused", f)


def build_isa(args):
    """The same oracle under each instruction set the CPU runs (mlsdeform.set_isa; the scalar backend too):
    on handles and beside them, float and double, rigid and affine."""
    for isa in ("scalar", "sse4_2", "avx2", "avx512", "backend=scalar"):
        for dt in DTYPES:
            for transform in ("rigid", "affine"):
                for placement, k in (("on", None), ("near", 6), ("near", 10)):

                    def f(g, isa=isa, dt=dt, transform=transform, placement=placement, k=k):
                        extra = {}
                        if isa == "backend=scalar":
                            extra["backend"] = "scalar"
                        elif isa not in mlsdeform.supported_isas():
                            raise Skip(f"this CPU lacks {isa}")
                        before = mlsdeform.active_isa()
                        try:
                            if not extra:
                                mlsdeform.set_isa(isa)
                            frames_case(g, dt, "automatic", transform, "mixed", "paper_constant", placement, k, extra)
                        finally:
                            mlsdeform.set_isa(before)

                    where = "on handles" if k is None else f"1e-{k} x spacing"
                    add("frames-isa", f"{isa} {where} {transform} {np.dtype(dt).name}", f)


def build_alias(args):
    """deform(out=, quaternions=, rotations=, scales=, linear=) with outputs that share memory with each other
    or with the targets: the result of the same call on separate arrays (bitwise), or a refusal naming it."""
    layouts = (
        "out and linear one buffer",
        "rotations and linear one buffer",
        "quaternions inside rotations",
        "scales inside out",
        "out over the targets",
    )
    for dt in DTYPES:
        for layout in layouts:

            def f(g, dt=dt, layout=layout):
                P, a, b, _ = handles(g, "points")
                n = 32
                V = np.ascontiguousarray(g.uniform(-1, 1, (n, 3)).astype(dt))
                P = np.ascontiguousarray(P.astype(dt))
                A, R, s, t = motion(g, "similarity")
                Q = moved(P, A, t, dt)
                ses = D_(V, points=P, transform="similarity")
                want = frame_arrays(n, dt, "similarity")
                X0 = ses.deform(points=Q.copy(), **want)
                buf = np.zeros(9 * n + 3 * n + 16, dt)
                kw = {}
                if layout == "out and linear one buffer":
                    kw["out"] = buf[: 3 * n].reshape(n, 3)
                    kw["linear"] = buf[3 : 3 + 9 * n].reshape(n, 3, 3)
                elif layout == "rotations and linear one buffer":
                    kw["rotations"] = buf[: 9 * n].reshape(n, 3, 3)
                    kw["linear"] = buf[9 : 9 + 9 * n].reshape(n, 3, 3)
                elif layout == "quaternions inside rotations":
                    kw["rotations"] = buf[: 9 * n].reshape(n, 3, 3)
                    kw["quaternions"] = buf[4 : 4 + 4 * n].reshape(n, 4)
                elif layout == "scales inside out":
                    kw["out"] = buf[: 3 * n].reshape(n, 3)
                    kw["scales"] = buf[5 : 5 + n]
                targets = Q.copy()
                if layout == "out over the targets":
                    big = np.zeros(3 * n, dt)
                    big[: 3 * len(Q)] = Q.ravel()
                    targets = big[: 3 * len(Q)].reshape(-1, 3)
                    kw["out"] = big.reshape(n, 3)
                try:
                    X = ses.deform(points=targets, **kw)
                except ValueError as e:
                    if any(w in str(e).lower() for w in ("overlap", "alias", "share", "same memory")):
                        return "clear error"
                    raise
                same(np.asarray(X), X0, f"{layout}: positions")
                for k, v in kw.items():
                    if k != "out":
                        same(v, want[k], f"{layout}: {k}")

            add("frames-alias", f"{layout} {np.dtype(dt).name}", f)
