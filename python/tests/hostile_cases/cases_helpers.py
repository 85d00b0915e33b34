"""The Python frame helpers mlsdeform.transform_normals and transform_tangents against float64 numpy (the
cofactor normal sign(det L) cof(L) n, L t with the bitangent sign), degenerate matrices, zero normals, and
outputs that overlap or alias the inputs (the result of a separate call, or a refusal)."""
import numpy as np

import mlsdeform

from support import random_rotation

from .common import DTYPES, EPS, TYPE, VALUE, Wrong, add, refused, same, within

KINDS = ("rotation", "similarity", "general", "shear", "reflection", "cond1e3", "cond1e6", "rank2", "rank1")


def matrices(g, kind, n):
    out = []
    for _ in range(n):
        R = random_rotation(g)
        if kind == "rotation":
            L = R
        elif kind == "similarity":
            L = g.uniform(0.3, 3) * R
        elif kind == "general":
            L = R @ (np.eye(3) + 0.45 * g.uniform(-1, 1, (3, 3)))
        elif kind == "shear":
            L = np.eye(3)
            L[0, 1] = g.uniform(-3, 3)
        elif kind == "reflection":
            L = g.uniform(0.5, 2) * R @ np.diag([1, -1, 1])
        elif kind in ("cond1e3", "cond1e6"):
            c = 1e3 if kind == "cond1e3" else 1e6
            L = R @ np.diag([1, g.uniform(1 / c, 1), 1 / c]) @ random_rotation(g)
        elif kind == "rank2":
            # exactly rank 2 in any precision: a third row that is the sum of the first two (small integers)
            L = g.integers(-4, 5, (3, 3)).astype(float)
            L[2] = L[0] + L[1]
        else:  # rank 1, exactly: an outer product of small integers (every 2 x 2 minor exactly 0)
            L = np.outer(g.integers(-3, 4, 3), g.integers(-3, 4, 3)).astype(float)
        out.append(L)
    return np.array(out)


def cof(L):
    return np.stack(
        [np.cross(L[:, 1], L[:, 2]), np.cross(L[:, 2], L[:, 0]), np.cross(L[:, 0], L[:, 1])], axis=1
    )  # cof(L) = det(L) L^-T: rows are the cross products of the other two rows


def normals_reference(L, N, singular=False):
    """(reference, its bound per row) in float64 from the dt-rounded L and N. The cofactors are 2 x 2
    determinants of L's entries: each carries 2 eps |L|_2^2 of rounding, so cof(L) n carries 3 x 2 eps
    |L|^2 |n| per component, at most 2 sqrt(3) x 3 eps |L|^2 |n| in norm, and its direction that over |cof n|;
    with the output's rounding and the renormalisation's (2 eps), 16 eps |L|^2 |n| / |cof n| + 4 eps bounds
    it (scaled by eps at use). Rows where cof n is exactly zero keep the input normal, unit (docs/api.md)."""
    C = cof(L)
    det = np.zeros(len(L)) if singular else np.linalg.det(L)
    m = np.einsum("nij,nj->ni", C, N) * np.where(det < 0, -1.0, 1.0)[:, None]
    norm = np.linalg.norm(m, axis=1)
    n_in = np.linalg.norm(N, axis=1)
    keep = norm == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        ref = np.where(keep[:, None], N / np.where(n_in == 0, 1, n_in)[:, None], m / norm[:, None])
        factor = np.where(keep, 4.0, 16 * np.linalg.norm(L, 2, axis=(1, 2)) ** 2 * n_in / norm + 4)
    ref[n_in == 0] = 0
    factor[n_in == 0] = 0  # a zero normal stays zero, bit for bit
    return ref, factor


def build(args):
    for dt in DTYPES:
        for kind in KINDS:

            def f(g, dt=dt, kind=kind):
                n = 64
                L = matrices(g, kind, n).astype(dt)
                N = g.normal(size=(n, 3)).astype(dt)
                N[::9] = 0
                ref, factor = normals_reference(L.astype(np.float64), N.astype(np.float64), kind == "rank2")
                if kind == "rank1":
                    # cof(L) is exactly zero: every normal is kept, unit
                    if np.any(factor[np.linalg.norm(N, axis=1) > 0] != 4):
                        raise Wrong("test scene error: rank-1 cofactor not zero")
                got = mlsdeform.transform_normals(L, N)
                if got.dtype != dt:
                    raise Wrong(f"dtype {got.dtype}, linear was {np.dtype(dt).name}")
                if kind == "rank2":
                    # det L = 0 exactly: sign(det L) is the docs' convention there, not defined; either sign
                    # of the collapsed plane's normal is taken.
                    flip = np.sum(got * ref, axis=1) < 0
                    ref[flip] *= -1
                within(got, ref, factor * EPS[dt], f"normals by {kind}")

            add("helpers-normals", f"transform_normals {kind} {np.dtype(dt).name}", f)

        def f(g, dt=dt):
            # A non-finite L keeps the input normal, unit (docs/api.md, Helpers); or a refusal naming it.
            n = 16
            L = matrices(g, "general", n).astype(dt)
            N = g.normal(size=(n, 3)).astype(dt)
            L[3, 2, 2] = np.inf
            L[7, 0, 1] = np.nan
            try:
                got = mlsdeform.transform_normals(L, N)
            except ValueError as e:
                if "finite" in str(e) or "linear" in str(e):
                    return "clear error"
                raise
            fin = np.isfinite(L).all(axis=(1, 2))
            ref = np.empty((n, 3))
            factor = np.empty(n)
            ref[fin], factor[fin] = normals_reference(L[fin].astype(np.float64), N[fin].astype(np.float64))
            for i in (3, 7):
                ref[i] = N[i] / np.linalg.norm(N[i].astype(np.float64))
                factor[i] = 4
            within(got, ref, factor * EPS[dt], "normals with non-finite matrices")

        add("helpers-normals", f"transform_normals non-finite linear rows {np.dtype(dt).name}", f)

        for kind in ("rotation", "similarity", "general", "shear", "reflection", "cond1e3"):

            def f(g, dt=dt, kind=kind):
                n = 64
                L = matrices(g, kind, n).astype(dt)
                T = np.hstack([g.normal(size=(n, 3)), np.where(g.uniform(size=(n, 1)) < 0.5, -1.0, 1.0)]).astype(dt)
                L64, T64 = L.astype(np.float64), T.astype(np.float64)
                m = np.einsum("nij,nj->ni", L64, T64[:, :3])
                norm = np.linalg.norm(m, axis=1)
                ref = m / norm[:, None]
                # L t: 3 products per component, 3 eps |L| |t| each side, over |L t|, plus the output's rounding
                # and the renormalisation's: 8 eps |L| |t| / |L t| + 4 eps.
                tol = (8 * np.linalg.norm(L64, 2, axis=(1, 2)) * np.linalg.norm(T64[:, :3], axis=1) / norm + 4) * EPS[
                    dt
                ]
                got = mlsdeform.transform_tangents(L, T)
                within(got[:, :3], ref, tol, f"tangents by {kind}")
                sign = np.where(np.linalg.det(L64) < 0, -1.0, 1.0) * T64[:, 3]
                same(got[:, 3].astype(np.float64), sign, "bitangent sign")

            add("helpers-tangents", f"transform_tangents {kind} {np.dtype(dt).name}", f)

        # Outputs that overlap the inputs: the result of a separate call (bitwise), or a refusal naming it.
        for fn_name, width in (("transform_normals", 3), ("transform_tangents", 4)):
            for layout in ("in place", "out one row ahead", "out one row behind", "out inside linear", "in = linear"):

                def f(g, dt=dt, fn_name=fn_name, width=width, layout=layout):
                    fn = getattr(mlsdeform, fn_name)
                    n = 40
                    L = matrices(g, "general", n).astype(dt)
                    x = g.normal(size=(n + 1, width)).astype(dt)
                    if width == 4:
                        x[:, 3] = np.where(g.uniform(size=n + 1) < 0.5, -1, 1)
                    if layout == "in place":
                        inp = x[:n]
                        want = fn(L, inp.copy())
                        r = fn(L, inp, out=inp)
                        same(r, want, "in place")
                        return
                    if layout in ("out one row ahead", "out one row behind"):
                        inp, out = (x[:-1], x[1:]) if layout == "out one row ahead" else (x[1:], x[:-1])
                        want = fn(L, inp.copy())
                        before = x.copy()
                        try:
                            r = fn(L, inp, out=out)
                        except ValueError as e:
                            if "overlap" in str(e).lower() or "out" in str(e).lower():
                                same(x, before, "a refused call's arrays")
                                return "clear error"
                            raise
                        same(np.asarray(r), want, f"out overlapping the input ({layout})")
                        return
                    buf = np.concatenate([L.ravel(), x.ravel()]).astype(dt)
                    Lv = buf[: 9 * n].reshape(n, 3, 3)
                    if layout == "out inside linear":
                        inp, out = x[:n].copy(), buf[9 : 9 + n * width].reshape(n, width)
                    else:  # the input rows are linear's own memory
                        inp, out = buf[: n * width].reshape(n, width), np.empty((n, width), dt)
                        if width == 4:
                            inp[:, 3] = np.where(inp[:, 3] < 0, -1, 1)
                        if not np.all(np.isfinite(inp)):
                            return None
                    want = fn(Lv.copy(), inp.copy())
                    before = buf.copy()
                    try:
                        r = fn(Lv, inp, out=out)
                    except ValueError as e:
                        if "overlap" in str(e).lower() or "out" in str(e).lower():
                            same(buf, before, "a refused call's arrays")
                            return "clear error"
                        raise
                    same(np.asarray(r), want, f"{layout}")

                add("helpers-alias", f"{fn_name} {layout} {np.dtype(dt).name}", f)

        # Refusals: shape, dtype, non-finite, non-contiguous or read-only outputs, nothing written.
        def bad_cases(g, dt):
            n = 12
            L = matrices(g, "general", n).astype(dt)
            N = g.normal(size=(n, 3)).astype(dt)
            return L, N

        for what, words, typ in (
            ("short normals", ["normals", "shape"], VALUE),
            ("NaN normal", ["not finite", "finite", "row"], VALUE),
            ("out of the other dtype", ["dtype", "out"], TYPE),
            ("out read-only", ["read-only", "writeable", "out"], VALUE),
            ("out strided", ["contiguous", "out"], VALUE),
            ("tangents with 3 columns", ["tangents", "shape"], VALUE),
        ):

            def f(g, dt=dt, what=what, words=words, typ=typ):
                L, N = bad_cases(g, dt)
                out = np.full_like(N, 7)
                fn = mlsdeform.transform_normals
                if what == "short normals":
                    args = (L, N[:5])
                elif what == "NaN normal":
                    N[4, 1] = np.nan
                    args = (L, N)
                elif what == "out of the other dtype":
                    out = np.full(N.shape, 7, np.float64 if dt == np.float32 else np.float32)
                    args = (L, N)
                elif what == "out read-only":
                    out.flags.writeable = False
                    args = (L, N)
                elif what == "out strided":
                    out = np.full((len(N), 6), 7, dt)[:, ::2]
                    args = (L, N)
                else:
                    fn = mlsdeform.transform_tangents
                    args = (L, N)
                    out = np.full((len(N), 4), 7, dt)
                return refused(lambda: fn(*args, out=out), typ, words, untouched=[out])

            add("helpers-refusals", f"{what} {np.dtype(dt).name}", f)
