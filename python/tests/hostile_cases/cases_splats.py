"""Gaussian splats (mlsdeform.rotate_splats, transform_splats_affine) against numpy float64: the quaternion
product, the log-scale offset, Sigma' = L Sigma L^T, and the SH bands rotated by least squares on the 3DGS
basis (f'(x) = f(Q^T x), written here from the textbook normalisations); the identity bit for bit, any thread
count bit for bit, overflow beyond float, overlapping in-place arrays."""
import numpy as np

import mlsdeform

from support import random_rotation

from .common import DTYPES, EPS, EPS64, VALUE, Wrong, add, refused, same, within

PI = np.pi
BANDS = {0: 0, 1: 3, 2: 8, 3: 15}  # coefficients per channel by SH degree


def basis(d):
    """3DGS's real SH bands 1-3 (orthonormal, Condon-Shortley phase), (m, 15)."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    n1, n2, n20, n22 = np.sqrt(3 / (4 * PI)), np.sqrt(15 / PI) / 2, np.sqrt(5 / PI) / 4, np.sqrt(15 / PI) / 4
    n33, n32, n31, n30 = (
        np.sqrt(35 / (2 * PI)) / 4,
        np.sqrt(105 / PI) / 2,
        np.sqrt(21 / (2 * PI)) / 4,
        np.sqrt(7 / PI) / 4,
    )
    b = [n1 * y, n1 * z, n1 * x, n2 * x * y, n2 * y * z, n20 * (3 * z * z - 1), n2 * x * z, n22 * (x * x - y * y)]
    b += [n33 * y * (3 * x * x - y * y), n32 * x * y * z, n31 * y * (5 * z * z - 1), n30 * z * (5 * z * z - 3)]
    b += [n31 * x * (5 * z * z - 1), n32 / 2 * z * (x * x - y * y), n33 * x * (x * x - 3 * y * y)]
    m = np.array([-1, 0, 1, -2, -1, 0, 1, 2, -3, -2, -1, 0, 1, 2, 3])
    return np.stack(b, axis=-1) * np.where(m % 2 != 0, -1, 1)


DIRS = np.random.default_rng(5).normal(size=(96, 3))
DIRS /= np.linalg.norm(DIRS, axis=1, keepdims=True)
B_AT = basis(DIRS)


def sh_rotated(sh, Q, k):
    """f'(x) = f(Q^T x) per splat and channel, by least squares on 96 directions (exact for bands 1-3:
    each band is closed under rotation, and 96 generic directions determine 15 coefficients)."""
    out = np.empty_like(sh)
    for i in range(len(sh)):
        Bq = basis(DIRS @ Q[i])  # rows: basis at Q^T d (d @ Q = (Q^T d)^T)
        for c in range(3):
            coeff = np.zeros(15)
            coeff[:k] = sh[i, c * k : (c + 1) * k]
            vals = Bq @ coeff
            out[i, c * k : (c + 1) * k] = np.linalg.lstsq(B_AT[:, :k], vals, rcond=None)[0]
    return out


def rotation_of(q):
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        1,
    )


def hamilton(a, b):
    w0, v0, w1, v1 = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    return np.hstack([w0 * w1 - np.sum(v0 * v1, axis=1, keepdims=True), w0 * v1 + w1 * v0 + np.cross(v0, v1)])


def splats(g, n, dt, k):
    return (
        np.ascontiguousarray((g.normal(size=(n, 4)) * 1.5).astype(dt)),
        np.ascontiguousarray((np.log(0.02) + 0.5 * g.normal(size=(n, 3))).astype(dt)),
        np.ascontiguousarray((0.3 * g.normal(size=(n, 3 * k))).astype(dt)),
    )


def sh_tol(sh, k, dt):
    # Per channel, the band's norm is kept by a rotation: the library reads the coefficients rounded to T (the
    # reference reads the same), works in double (docs/splats.md: a few hundred eps64 of the band's norm; the
    # Lebedev rule is exact) and rounds once to T (eps/2 of the largest); the least squares here, on a basis
    # of condition number below 10, adds 100 eps64. eps_T + 1000 eps64 of the channel's norm bounds it.
    n3 = np.linalg.norm(sh.reshape(len(sh), 3, k), axis=2)
    return np.repeat((EPS[dt] + 1000 * EPS64) * n3, k, axis=1)


def covariance(q, ls):
    R = rotation_of(q)
    return np.einsum("nij,nj,nkj->nik", R, np.exp(2 * ls), R)


def build(args):
    for dt in DTYPES:
        nm = np.dtype(dt).name
        for degree, k in BANDS.items():
            for similarity in (False, True):

                def f(g, dt=dt, k=k, similarity=similarity):
                    n = 40
                    rot, ls, sh = splats(g, n, dt, k)
                    q = g.normal(size=(n, 4))
                    q /= np.linalg.norm(q, axis=1, keepdims=True)
                    q = q.astype(dt)
                    s = g.uniform(0.3, 3, n).astype(dt) if similarity else None
                    r0, l0, h0 = (x.astype(np.float64) for x in (rot, ls, sh))
                    mlsdeform.rotate_splats(q, s, rotations=rot, log_scales=ls, sh_rest=sh if k else None)
                    q64 = q.astype(np.float64)
                    want = hamilton(q64 / np.linalg.norm(q64, axis=1, keepdims=True), r0)
                    want /= np.linalg.norm(want, axis=1, keepdims=True)
                    got = rot.astype(np.float64)
                    d = np.minimum(np.linalg.norm(got - want, axis=1), np.linalg.norm(got + want, axis=1))
                    # The product in double, normalised, rounded to T: 4 eps of a unit vector.
                    within(d, np.zeros(n), 4 * EPS[dt], "rot_* = normalise(q_R q)")
                    add_ = np.log(s.astype(np.float64))[:, None] if similarity else 0.0
                    ref = l0 + add_
                    tol = np.broadcast_to(EPS[dt] * (np.abs(ref) + np.abs(add_) + 1), ref.shape)
                    within(ls.ravel(), ref.ravel(), tol.ravel(), "log scales + log(s)")
                    if k:
                        refsh = sh_rotated(h0, rotation_of(q64), k)
                        within(sh.ravel(), refsh.ravel(), sh_tol(h0, k, dt).ravel(), "SH rotated")

                add("splats-rotate", f"rotate_splats degree {degree} {'similarity' if similarity else 'rigid'} {nm}", f)

        for kind in ("general", "shear", "reflection", "similarity"):
            for degree in (0, 3):

                def f(g, dt=dt, kind=kind, k=BANDS[degree]):
                    n = 30
                    rot, ls, sh = splats(g, n, dt, k)
                    L = []
                    for _ in range(n):
                        R = random_rotation(g)
                        if kind == "general":
                            L.append(R @ (np.eye(3) + 0.4 * g.uniform(-1, 1, (3, 3))))
                        elif kind == "shear":
                            M = np.eye(3)
                            M[0, 2] = g.uniform(-1.5, 1.5)
                            L.append(R @ M)
                        elif kind == "reflection":
                            L.append(g.uniform(0.5, 2) * R @ np.diag([1, 1, -1]))
                        else:
                            L.append(g.uniform(0.5, 2) * R)
                    L = np.array(L).astype(dt)
                    L64 = L.astype(np.float64)
                    r0, l0, h0 = (x.astype(np.float64) for x in (rot, ls, sh))
                    mlsdeform.transform_splats_affine(L, rotations=rot, log_scales=ls, sh_rest=sh if k else None)
                    C = np.einsum("nij,njk,nlk->nil", L64, covariance(r0, l0), L64)
                    got = covariance(rot.astype(np.float64), ls.astype(np.float64))
                    # Decomposed in double, the quaternion and log-scales rounded to T: the covariance rebuilt
                    # from them is off by 2 x 4 eps (the rotation, on both sides) plus 2 eps |log s| (each
                    # exp(2 l)) of its norm, and the eigen-solver's 100 eps64 kappa-free part (symmetric).
                    nC = np.linalg.norm(C, 2, axis=(1, 2))
                    tol = (8 + 2 * np.abs(ls.astype(np.float64)).max(axis=1)) * EPS[dt] * nC + 100 * EPS64 * nC
                    within(got.reshape(n, 9), C.reshape(n, 9), tol, "Sigma' = L Sigma L^T")
                    if k:
                        U, _, Vt = np.linalg.svd(L64)
                        Q = U @ Vt  # the polar factor (improper for a reflection: f'(x) = f(Q^T x) exactly)
                        refsh = sh_rotated(h0, Q, k)
                        # The polar factor's sensitivity: its error is eps kappa-free for these L (cond <= 5).
                        within(sh.ravel(), refsh.ravel(), 4 * sh_tol(h0, k, dt).ravel(), "SH by L's polar rotation")

                add("splats-affine", f"transform_splats_affine {kind} degree {degree} {nm}", f)

        def f(g, dt=dt):
            n = 25
            rot, ls, sh = splats(g, n, dt, 15)
            rot[3] = [7, 0, 0, 0]  # unnormalised, pure w
            before = rot.copy(), ls.copy(), sh.copy()
            q = np.tile(np.array([1.0, 0, 0, 0], dt), (n, 1))
            q[::2, 0] = -1
            mlsdeform.rotate_splats(q, np.ones(n, dt), rotations=rot, log_scales=ls, sh_rest=sh)
            mlsdeform.transform_splats_affine(np.tile(np.eye(3, dtype=dt), (n, 1, 1)), rotations=rot, log_scales=ls)
            for a, b, name in zip((rot, ls, sh), before, ("rotations", "log_scales", "sh_rest")):
                same(a, b, f"identity: {name}")

        add("splats-identity", f"q = +-1 and L = I keep every bit {nm}", f)

        def f(g, dt=dt):
            n = 50
            rot, ls, sh = splats(g, n, dt, 15)
            q = g.normal(size=(n, 4))
            q = (q / np.linalg.norm(q, axis=1, keepdims=True)).astype(dt)
            s = g.uniform(0.5, 2, n).astype(dt)
            results = []
            for threads in (1, 0, 3):
                a = rot.copy(), ls.copy(), sh.copy()
                mlsdeform.rotate_splats(q, s, rotations=a[0], log_scales=a[1], sh_rest=a[2], threads=threads)
                results.append(a)
            for a in results[1:]:
                for x, y in zip(a, results[0]):
                    same(x, y, "another thread count")

        add("splats-threads", f"threads 1, 0, 3 bitwise {nm}", f)

        # Overlapping in-place arrays: one buffer seen as two outputs has no defined result: refused.
        def f(g, dt=dt):
            n = 20
            buf = np.zeros(7 * n, dt)
            rot = buf[: 4 * n].reshape(n, 4)
            ls = buf[n : 4 * n].reshape(n, 3)
            rot[:] = g.normal(size=(n, 4))
            q = g.normal(size=(n, 4))
            q = (q / np.linalg.norm(q, axis=1, keepdims=True)).astype(dt)
            return refused(
                lambda: mlsdeform.rotate_splats(q, np.full(n, 2, dt), rotations=rot, log_scales=ls),
                VALUE,
                ["overlap", "alias", "same memory", "share"],
            )

        add("splats-alias", f"rotations and log_scales share memory {nm}", f)

        def f(g, dt=dt):
            # The transform's quaternions are the splats' own array: each splat reads both before writing,
            # or the call refuses; the result is normalise(q q) per splat.
            n = 20
            rot = g.normal(size=(n, 4))
            rot = (rot / np.linalg.norm(rot, axis=1, keepdims=True)).astype(dt)
            want = hamilton(rot.astype(np.float64), rot.astype(np.float64))
            want /= np.linalg.norm(want, axis=1, keepdims=True)
            try:
                mlsdeform.rotate_splats(rot, rotations=rot)
            except ValueError as e:
                if any(w in str(e).lower() for w in ("overlap", "alias", "same memory", "share")):
                    return "clear error"
                raise
            got = rot.astype(np.float64)
            d = np.minimum(np.linalg.norm(got - want, axis=1), np.linalg.norm(got + want, axis=1))
            within(d, np.zeros(n), 4 * EPS[dt], "q given as its own splat")

        add("splats-alias", f"quaternions = rotations (same array) {nm}", f)

        def f(g, dt=dt):
            # sh_rest's memory begins inside linear's: the result of the same call on separate arrays, or a
            # refusal naming the overlap.
            n = 8
            buf = np.zeros(n * 45 + 9 * n, dt)
            L = buf[: 9 * n].reshape(n, 3, 3)
            L[:] = [random_rotation(g) * 1.5 for _ in range(n)]
            sh = buf[9 * n - 9 : 9 * n - 9 + 45 * n].reshape(n, 45)
            sh[1:] = 0.3 * g.normal(size=(n - 1, 45))
            Lc, shc = L.copy(), sh.copy()
            mlsdeform.transform_splats_affine(Lc, sh_rest=shc)
            before = buf.copy()
            try:
                mlsdeform.transform_splats_affine(L, sh_rest=sh)
            except ValueError as e:
                if any(w in str(e).lower() for w in ("overlap", "alias", "share")):
                    same(buf, before, "a refused call's buffer")
                    return "clear error"
                raise
            same(sh, shc, "sh_rest overlapping linear")

        add("splats-alias", f"sh_rest overlapping linear {nm}", f)

        # Bad input: refused naming the splat, nothing written.
        for what in ("NaN in q", "q of length 2", "scale 0", "scale -1", "zero rot", "inf in sh", "singular L"):

            def f(g, dt=dt, what=what):
                n = 10
                rot, ls, sh = splats(g, n, dt, 15)
                q = np.tile(np.array([0.0, 1, 0, 0], dt), (n, 1))
                s = np.ones(n, dt)
                if what == "NaN in q":
                    q[6, 2] = np.nan
                elif what == "q of length 2":
                    q[6] *= 2
                elif what == "scale 0":
                    s[6] = 0
                elif what == "scale -1":
                    s[6] = -1
                elif what == "zero rot":
                    rot[6] = 0
                elif what == "inf in sh":
                    sh[6, 40] = np.inf
                if what == "singular L":
                    L = np.tile(np.eye(3, dtype=dt), (n, 1, 1))
                    L[6, 2] = L[6, 1]
                    call = lambda: mlsdeform.transform_splats_affine(L, rotations=rot, log_scales=ls)  # noqa: E731
                else:
                    call = lambda: mlsdeform.rotate_splats(q, s, rotations=rot, log_scales=ls, sh_rest=sh)  # noqa: E731
                return refused(call, VALUE, ["splat 6", "6"], untouched=[rot, ls, sh])

            add("splats-refusals", f"{what} {nm}", f)

    # Overflow: float32 coefficients near float's maximum whose rotation leaves float's range must be refused
    # (never written as inf); those that stay within it must come out right.
    for variant in ("band 1 turned onto an axis", "band 2 near max", "log scale + log s beyond float"):
        for big in (1.0e38, 3.0e38):

            def f(g, variant=variant, big=big):
                n = 4
                rot, ls, sh = splats(g, n, np.float32, 15)
                h0 = sh.astype(np.float64)
                q = np.tile(np.array([1.0, 0, 0, 0]), (n, 1))
                s = np.ones(n, np.float32)
                if variant.startswith("band 1"):
                    sh[:, 0:3] = np.float32(big)  # v = (big, big, big) for R: |v| = 1.7 big
                    c = np.cos(np.pi / 8)
                    q[:] = [c, np.sqrt(1 - c * c), 0, 0]
                elif variant.startswith("band 2"):
                    sh[:, 3:8] = np.float32(big)
                    q[:] = random_rotation(g)[0:1, :].tolist()[0] + [0]
                    q /= np.linalg.norm(q, axis=1, keepdims=True)
                else:
                    ls[:] = np.float32(big)
                    s[:] = 1e30
                h0 = sh.astype(np.float64)
                l0 = ls.astype(np.float64)
                q32 = q.astype(np.float32)
                before = [x.copy() for x in (rot, ls, sh)]
                ref_sh = sh_rotated(h0, rotation_of(q32.astype(np.float64)), 15)
                ref_ls = l0 + np.log(s.astype(np.float64))[:, None]
                fmax = float(np.finfo(np.float32).max)
                over = np.abs(ref_sh).max() > fmax or np.abs(ref_ls).max() > fmax
                try:
                    mlsdeform.rotate_splats(q32, s, rotations=rot, log_scales=ls, sh_rest=sh)
                except ValueError as e:
                    if not over and "too large" not in str(e):
                        raise Wrong(f"refused a result float holds, naming no reason: {e}")
                    for a, b in zip((rot, ls, sh), before):
                        same(a, b, "a refused call's arrays")
                    return "clear error"
                if over:
                    raise Wrong(f"a result beyond float's range accepted: sh {np.abs(sh).max()}, ls {np.abs(ls).max()}")
                within(sh.ravel(), ref_sh.ravel(), sh_tol(h0, 15, np.float32).ravel(), "SH near float's maximum")
                tol = (EPS[np.float32] * (np.abs(ref_ls) + 1)).ravel()
                within(ls.ravel(), ref_ls.ravel(), tol, "log scales near float's maximum")

            add("splats-overflow", f"{variant} at {big:g} float32", f)
